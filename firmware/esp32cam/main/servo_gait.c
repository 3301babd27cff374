#include "servo_gait.h"

#include <stdint.h>

#include "board.h"
#include "driver/ledc.h"
#include "esp_log.h"
#include "esp_timer.h"
#include "freertos/FreeRTOS.h"
#include "sdkconfig.h"
#include "soc/soc_caps.h"

static const char* TAG = "servo";

/* The camera's XCLK holds LEDC low-speed timer 0 / channel 0. On the ESP32
 * the servos get the high-speed group, which shares nothing with it. */
#if SOC_LEDC_SUPPORT_HS_MODE
#define SERVO_MODE LEDC_HIGH_SPEED_MODE
#define SERVO_TIMER LEDC_TIMER_0
#define SERVO_CHANNEL0 0
#else
#define SERVO_MODE LEDC_LOW_SPEED_MODE
#define SERVO_TIMER LEDC_TIMER_1
#define SERVO_CHANNEL0 2
#endif
#define SERVO_HZ 50
#define SERVO_PERIOD_US (1000000 / SERVO_HZ)
#define SERVO_RES_BITS 14 /* 20 ms / 16384: 1.2 us steps */
#define GAIT_TICK_US 20000

/* Key poses in degrees from each servo's centre, played in a loop, each
 * reached from the previous one by linear interpolation over step_ms.
 * Written for a two-servo walker: servo 0 swings the legs fore and aft,
 * servo 1 tilts the body to lift one side's feet; servos 2 and 3 (spare
 * pins) stay centred. Tune the table to the robot's mechanics. */
typedef struct pose {
  int8_t deg[SERVO_MAX];
} pose;

typedef struct gait_def {
  const char* name;
  uint16_t step_ms;
  uint8_t n;
  pose key[4];
} gait_def;

static const gait_def GAITS[] = {
    {"stand", 0, 0, {{{0, 0, 0, 0}}}},
    /* tilt right, swing forward, tilt left, swing back: 0.8 s a stride */
    {"walk", 200, 4, {{{-20, 12, 0, 0}}, {{20, 12, 0, 0}}, {{20, -12, 0, 0}}, {{-20, -12, 0, 0}}}},
    /* the same, shorter and slower: 1.6 s a stride */
    {"creep", 400, 4, {{{-12, 8, 0, 0}}, {{12, 8, 0, 0}}, {{12, -8, 0, 0}}, {{-12, -8, 0, 0}}}},
};
#define GAIT_COUNT ((int)(sizeof(GAITS) / sizeof(GAITS[0])))

static const int s_gpio[SERVO_MAX] = SERVO_GPIOS;
static portMUX_TYPE s_mux = portMUX_INITIALIZER_UNLOCKED;
static int s_moving;
static int s_gait = 1;
static int64_t s_walk_start_us;
static esp_timer_handle_t s_timer;

static void set_angle(int i, int deg) {
  const int min_us = CONFIG_RUMI_SERVO_MIN_US, max_us = CONFIG_RUMI_SERVO_MAX_US;
  if (deg < -90) deg = -90;
  if (deg > 90) deg = 90;
  const int us = (min_us + max_us) / 2 + deg * (max_us - min_us) / 180;
  const uint32_t duty = (uint32_t)(((uint64_t)us << SERVO_RES_BITS) / SERVO_PERIOD_US);
  const ledc_channel_t ch = (ledc_channel_t)(SERVO_CHANNEL0 + i);
  ledc_set_duty(SERVO_MODE, ch, duty);
  ledc_update_duty(SERVO_MODE, ch);
}

/* The pose t_us after the robot started walking: the first step goes from
 * the neutral stance to the first key pose, then the key poses loop. */
static void pose_at(const gait_def* g, int64_t t_us, int deg[SERVO_MAX]) {
  for (int i = 0; i < SERVO_MAX; ++i) deg[i] = 0;
  if (g->n == 0 || g->step_ms == 0) return;
  const int64_t step = (int64_t)g->step_ms * 1000;
  const pose* a;
  const pose* b;
  int64_t into;
  if (t_us < step) {
    static const pose neutral = {{0, 0, 0, 0}};
    a = &neutral;
    b = &g->key[0];
    into = t_us;
  } else {
    const int64_t k = (t_us - step) / step;
    a = &g->key[k % g->n];
    b = &g->key[(k + 1) % g->n];
    into = (t_us - step) % step;
  }
  for (int i = 0; i < SERVO_MAX; ++i)
    deg[i] = a->deg[i] + (int)((b->deg[i] - a->deg[i]) * into / step);
}

static void gait_tick(void* arg) {
  (void)arg;
  int moving, gait;
  int64_t start;
  portENTER_CRITICAL(&s_mux);
  moving = s_moving;
  gait = s_gait;
  start = s_walk_start_us;
  portEXIT_CRITICAL(&s_mux);
  int deg[SERVO_MAX];
  if (moving) {
    pose_at(&GAITS[gait], esp_timer_get_time() - start, deg);
  } else {
    pose_at(&GAITS[0], 0, deg); /* neutral stance */
  }
  for (int i = 0; i < SERVO_MAX; ++i)
    if (s_gpio[i] >= 0) set_angle(i, deg[i]);
}

void servo_gait_set(int moving, int gait) {
  if (gait < 0 || gait >= GAIT_COUNT) {
    ESP_LOGW(TAG, "no gait %d: walking with gait 1 (%s)", gait, GAITS[1].name);
    gait = 1;
  }
  portENTER_CRITICAL(&s_mux);
  if (moving && (!s_moving || s_gait != gait)) s_walk_start_us = esp_timer_get_time();
  s_moving = moving ? 1 : 0;
  s_gait = gait;
  portEXIT_CRITICAL(&s_mux);
  if (moving) {
    ESP_LOGI(TAG, "walking: gait %d (%s)", gait, GAITS[gait].name);
  } else {
    ESP_LOGI(TAG, "halted: neutral stance");
  }
}

esp_err_t servo_gait_start(void) {
  const ledc_timer_config_t t = {
      .speed_mode = SERVO_MODE,
      .duty_resolution = (ledc_timer_bit_t)SERVO_RES_BITS,
      .timer_num = SERVO_TIMER,
      .freq_hz = SERVO_HZ,
      .clk_cfg = LEDC_AUTO_CLK,
  };
  esp_err_t err = ledc_timer_config(&t);
  if (err != ESP_OK) {
    ESP_LOGE(TAG, "ledc_timer_config: %s", esp_err_to_name(err));
    return err;
  }
  int used = 0;
  for (int i = 0; i < SERVO_MAX; ++i) {
    if (s_gpio[i] < 0) continue;
    const ledc_channel_config_t c = {
        .gpio_num = s_gpio[i],
        .speed_mode = SERVO_MODE,
        .channel = (ledc_channel_t)(SERVO_CHANNEL0 + i),
        .intr_type = LEDC_INTR_DISABLE,
        .timer_sel = SERVO_TIMER,
        .duty = 0, /* no pulse until the neutral stance below */
        .hpoint = 0,
    };
    err = ledc_channel_config(&c);
    if (err != ESP_OK) {
      ESP_LOGE(TAG, "servo %d on GPIO %d: %s", i, s_gpio[i], esp_err_to_name(err));
      return err;
    }
    set_angle(i, 0);
    used++;
  }
  const esp_timer_create_args_t targs = {
      .callback = gait_tick,
      .arg = NULL,
      .dispatch_method = ESP_TIMER_TASK,
      .name = "gait",
  };
  err = esp_timer_create(&targs, &s_timer);
  if (err == ESP_OK) err = esp_timer_start_periodic(s_timer, GAIT_TICK_US);
  if (err != ESP_OK) return err;
  ESP_LOGI(TAG, "%d servo(s) at %d Hz, neutral stance", used, SERVO_HZ);
  return ESP_OK;
}
