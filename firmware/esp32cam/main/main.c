/* rumi robot firmware for the AI-Thinker ESP32-CAM: driver glue only.
 *
 * Everything that is not a driver call (framing, fragmentation and NACK
 * retransmission, IMU batching, halt/resume and camera commands with their
 * acknowledgements, clock sync, heartbeats, the fail-safe) is rr_robot from
 * firmware/robot, compiled here by components/rumi_link and tested on the
 * host. This file gives it its hardware (rr_hw) and its tasks:
 *
 *   rr_camera  core 1  grab the latest JPEG, rr_send_frame, paced to the fps
 *   rr_imu     core 1  MPU6050 at CONFIG_RUMI_IMU_RATE_HZ, rr_add_imu
 *   rr_rx      core 0  recvfrom the ground station, rr_on_datagram
 *   rr_poll    core 0  rr_poll every 5 ms (heartbeat, IMU batch age, fail-safe)
 *
 * rr_robot is not thread-safe: every rr_* call, and every read of what the
 * rr_hw callbacks write, happens with s_lock held. The callbacks run inside
 * rr_* calls, so they already hold it. Every task feeds the task watchdog. */
#include <errno.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/time.h>
#include <unistd.h>

#include "camera.h"
#include "esp_heap_caps.h"
#include "esp_log.h"
#include "esp_random.h"
#include "esp_system.h"
#include "esp_task_wdt.h"
#include "esp_timer.h"
#include "freertos/FreeRTOS.h"
#include "freertos/semphr.h"
#include "freertos/task.h"
#include "lwip/inet.h"
#include "lwip/sockets.h"
#include "mpu6050.h"
#include "nvs.h"
#include "nvs_flash.h"
#include "rumi_robot.h"
#include "sdkconfig.h"
#include "servo_gait.h"
#include "wifi_sta.h"

static const char* TAG = "rumi";

#define POLL_MS 5
#define STATS_LOG_US (5 * 1000000LL)
#define RX_TIMEOUT_MS 200
#define SEND_RETRIES 5
#define MAX_FPS_MILLI 30000 /* 30 fps: the OV2640's JPEG rate at QVGA */

static rr_robot* s_robot; /* in PSRAM, allocated once at boot */
static SemaphoreHandle_t s_lock;

static int s_sock = -1;
static struct sockaddr_in s_ground;
static uint32_t s_foreign_datagrams; /* rr_rx only */

/* Camera settings: written by hw_set_camera (inside rr_on_datagram, lock
 * held), read by the camera task with the lock held. */
static struct {
  bool ok;
  framesize_t size;
  int quality;
  uint32_t interval_us;
  int skip; /* frames to drop after a frame size change (half-switched) */
} s_cam;

static TaskHandle_t s_imu_task;

static void robot_lock(void) { xSemaphoreTake(s_lock, portMAX_DELAY); }
static void robot_unlock(void) { xSemaphoreGive(s_lock); }

static void sleep_us(int64_t us) {
  TickType_t t = pdMS_TO_TICKS((uint32_t)((us + 999) / 1000));
  vTaskDelay(t > 0 ? t : 1);
}

static void watch_this_task(void) {
  esp_err_t err = esp_task_wdt_add(NULL);
  if (err != ESP_OK) ESP_LOGW(TAG, "esp_task_wdt_add: %s (task watchdog off?)", esp_err_to_name(err));
}

/* ---- rr_hw ---------------------------------------------------------------- */

static int hw_send(void* ctx, const uint8_t* data, size_t len) {
  (void)ctx;
  if (s_sock < 0 || !wifi_sta_connected()) return -1;
  for (int i = 0; i < SEND_RETRIES; ++i) {
    ssize_t n = sendto(s_sock, data, len, 0, (const struct sockaddr*)&s_ground, sizeof(s_ground));
    if (n == (ssize_t)len) return 0;
    /* ENOMEM: the Wi-Fi TX buffers are full (a burst of frame fragments);
     * give the driver a tick to drain them. */
    if (n < 0 && errno == ENOMEM) {
      vTaskDelay(1);
      continue;
    }
    return -1;
  }
  return -1;
}

static uint64_t hw_now_us(void* ctx) {
  (void)ctx;
  return (uint64_t)esp_timer_get_time();
}

static void hw_set_motion(void* ctx, int moving, int gait) {
  (void)ctx;
  servo_gait_set(moving, gait);
}

static int hw_rssi_dbm(void* ctx) {
  (void)ctx;
  return wifi_sta_rssi();
}

/* rr passes its last accepted settings, 0 for one never set: 0 keeps the
 * current value. Checks everything before touching the sensor. */
static int hw_set_camera(void* ctx, int width, int height, int quality, int fps_milli) {
  (void)ctx;
  framesize_t size = s_cam.size;
  if ((width || height) && camera_framesize_for(width, height, &size) != 0) {
    ESP_LOGW(TAG, "frame size %dx%d not supported", width, height);
    return -1;
  }
  if (quality == 0) quality = s_cam.quality;
  if (quality < 1 || quality > 63) return -1;
  uint32_t interval_us = s_cam.interval_us;
  if (fps_milli != 0) {
    if (fps_milli < 0 || fps_milli > MAX_FPS_MILLI) return -1;
    interval_us = (uint32_t)(1000000000ULL / (uint64_t)fps_milli);
  }
  if (camera_apply(size, quality) != 0) return -1;
  if (size != s_cam.size) s_cam.skip = 2;
  s_cam.size = size;
  s_cam.quality = quality;
  s_cam.interval_us = interval_us;
  ESP_LOGI(TAG, "camera: frame size %d, quality %d, %u us a frame", (int)size, quality, (unsigned)interval_us);
  return 0;
}

/* ---- tasks ---------------------------------------------------------------- */

static void camera_task(void* arg) {
  (void)arg;
  watch_this_task();
  int64_t next_due = esp_timer_get_time();
  uint32_t failures = 0, too_large = 0;
  for (;;) {
    esp_task_wdt_reset();
    if (!wifi_sta_connected()) {
      wifi_sta_wait_connected(500);
      next_due = esp_timer_get_time();
      continue;
    }
    int64_t now = esp_timer_get_time();
    if (now < next_due) {
      sleep_us(next_due - now);
      continue;
    }
    camera_fb_t* fb = esp_camera_fb_get(); /* the latest frame (CAMERA_GRAB_LATEST) */
    if (!fb) {
      robot_lock();
      s_robot->stats.frames_skipped++; /* heartbeat: "too large or camera failures" */
      robot_unlock();
      if ((failures++ % 50) == 0) ESP_LOGW(TAG, "no frame from the camera (%u so far)", (unsigned)failures);
      sleep_us(10000);
      continue;
    }
    /* Capture time: the driver's esp_timer_get_time() at the frame's VSYNC,
     * the robot clock rr and the time sync use. */
    uint64_t t_us = (uint64_t)fb->timestamp.tv_sec * 1000000ULL + (uint64_t)fb->timestamp.tv_usec;
    if (t_us == 0) t_us = (uint64_t)esp_timer_get_time();
    uint32_t interval_us;
    bool not_sent = false;
    robot_lock();
    interval_us = s_cam.interval_us;
    if (s_cam.skip > 0) {
      s_cam.skip--;
    } else if (fb->format == PIXFORMAT_JPEG) {
      /* -1: larger than RR_FRAME_CAP (counted in frames_skipped) */
      not_sent = rr_send_frame(s_robot, fb->buf, fb->len, (uint16_t)fb->width, (uint16_t)fb->height,
                               RL_FORMAT_JPEG, (uint8_t)s_cam.quality, t_us) < 0;
    }
    robot_unlock();
    size_t len = fb->len;
    esp_camera_fb_return(fb);
    if (not_sent && (too_large++ % 50) == 0)
      ESP_LOGW(TAG, "JPEG of %u bytes not sent (over %u; %u so far): raise the quality number",
               (unsigned)len, (unsigned)RR_FRAME_CAP, (unsigned)too_large);
    next_due += interval_us;
    if (next_due < now) next_due = now; /* fell behind: no burst to catch up */
  }
}

static void imu_tick(void* arg) {
  (void)arg;
  if (s_imu_task) xTaskNotifyGive(s_imu_task);
}

static void imu_task(void* arg) {
  (void)arg;
  watch_this_task();
  bool ok = mpu6050_start(CONFIG_RUMI_IMU_RATE_HZ) == ESP_OK;
  int64_t next_retry_us = esp_timer_get_time() + 1000000;
  uint32_t errors_in_row = 0;
  for (;;) {
    esp_task_wdt_reset();
    /* pdTRUE: after a stall read once, not once per missed tick (the sensor
     * holds only its latest sample). */
    if (ulTaskNotifyTake(pdTRUE, pdMS_TO_TICKS(100)) == 0) continue;
    if (!ok) {
      if (esp_timer_get_time() >= next_retry_us) {
        ok = mpu6050_start(CONFIG_RUMI_IMU_RATE_HZ) == ESP_OK;
        next_retry_us = esp_timer_get_time() + 1000000;
      }
      continue;
    }
    mpu6050_sample m;
    int64_t t0 = esp_timer_get_time();
    if (mpu6050_read(&m) != ESP_OK) {
      if (++errors_in_row >= 20) {
        ESP_LOGE(TAG, "IMU: %u reads failed in a row, reconfiguring", (unsigned)errors_in_row);
        ok = false;
        errors_in_row = 0;
      }
      continue;
    }
    int64_t t1 = esp_timer_get_time();
    errors_in_row = 0;
    if (!wifi_sta_connected()) continue;
    rl_imu_sample s;
    s.t_us = (uint64_t)(t0 + (t1 - t0) / 2);
    memcpy(s.accel, m.accel, sizeof(s.accel));
    memcpy(s.gyro, m.gyro, sizeof(s.gyro));
    robot_lock();
    rr_add_imu(s_robot, &s);
    robot_unlock();
  }
}

static void rx_task(void* arg) {
  (void)arg;
  watch_this_task();
  /* One byte more than the largest datagram: a longer one arrives truncated
   * to a length rl_parse rejects. */
  static uint8_t buf[RL_MAX_DATAGRAM + 1];
  for (;;) {
    esp_task_wdt_reset();
    struct sockaddr_in from;
    socklen_t from_len = sizeof(from);
    ssize_t n = recvfrom(s_sock, buf, sizeof(buf), 0, (struct sockaddr*)&from, &from_len);
    if (n < 0) {
      if (errno != EAGAIN && errno != EWOULDBLOCK) {
        ESP_LOGW(TAG, "recvfrom: errno %d", errno);
        vTaskDelay(pdMS_TO_TICKS(100));
      }
      continue; /* SO_RCVTIMEO: nothing for RX_TIMEOUT_MS */
    }
    if (from.sin_addr.s_addr != s_ground.sin_addr.s_addr) {
      s_foreign_datagrams++;
      continue;
    }
    robot_lock();
    rr_on_datagram(s_robot, buf, (size_t)n);
    robot_unlock();
  }
}

static void poll_task(void* arg) {
  (void)arg;
  watch_this_task();
  const TickType_t period = pdMS_TO_TICKS(POLL_MS) > 0 ? pdMS_TO_TICKS(POLL_MS) : 1;
  TickType_t last = xTaskGetTickCount();
  int64_t next_log = esp_timer_get_time() + STATS_LOG_US;
  for (;;) {
    xTaskDelayUntil(&last, period);
    esp_task_wdt_reset();
    robot_lock();
    rr_poll(s_robot);
    robot_unlock();

    int64_t now = esp_timer_get_time();
    if (now < next_log) continue;
    next_log = now + STATS_LOG_US;
    rr_stats st;
    int moving, failsafe;
    robot_lock();
    st = s_robot->stats;
    moving = rr_moving(s_robot);
    failsafe = s_robot->failsafe;
    robot_unlock();
    ESP_LOGI(TAG,
             "frames %u (skipped %u), fragments %u (+%u resent, %u NACKs too old), imu %u, "
             "send failures %u, controls %u, bad %u, foreign %u, unauthenticated %u, auth failures %u, "
             "replays %u, sessions %u, %s, rssi %d dBm, free internal %u B, PSRAM %u B",
             (unsigned)st.frames_sent, (unsigned)st.frames_skipped, (unsigned)st.fragments_sent,
             (unsigned)st.fragments_resent, (unsigned)st.nacks_too_old, (unsigned)st.imu_samples,
             (unsigned)st.send_failures, (unsigned)st.controls, (unsigned)st.bad_datagrams,
             (unsigned)s_foreign_datagrams, (unsigned)st.unauthenticated, (unsigned)st.auth_failures,
             (unsigned)st.replays, (unsigned)st.sessions, moving ? "walking" : (failsafe ? "FAIL-SAFE halt" : "halted"),
             wifi_sta_rssi(), (unsigned)heap_caps_get_free_size(MALLOC_CAP_INTERNAL),
             (unsigned)heap_caps_get_free_size(MALLOC_CAP_SPIRAM));
  }
}

/* ---- boot ----------------------------------------------------------------- */

static esp_err_t link_open(void) {
  memset(&s_ground, 0, sizeof(s_ground));
  s_ground.sin_family = AF_INET;
  s_ground.sin_port = htons(CONFIG_RUMI_GROUND_PORT);
  if (inet_pton(AF_INET, CONFIG_RUMI_GROUND_IP, &s_ground.sin_addr) != 1) {
    ESP_LOGE(TAG, "ground station address \"%s\" is not an IPv4 address", CONFIG_RUMI_GROUND_IP);
    return ESP_ERR_INVALID_ARG;
  }
  int s = socket(AF_INET, SOCK_DGRAM, IPPROTO_UDP);
  if (s < 0) {
    ESP_LOGE(TAG, "socket: errno %d", errno);
    return ESP_FAIL;
  }
  struct sockaddr_in local;
  memset(&local, 0, sizeof(local));
  local.sin_family = AF_INET;
  local.sin_port = htons(CONFIG_RUMI_LOCAL_PORT);
  local.sin_addr.s_addr = htonl(INADDR_ANY);
  if (bind(s, (struct sockaddr*)&local, sizeof(local)) != 0) {
    ESP_LOGE(TAG, "bind to port %d: errno %d", CONFIG_RUMI_LOCAL_PORT, errno);
    close(s);
    return ESP_FAIL;
  }
  struct timeval tv = {.tv_sec = 0, .tv_usec = RX_TIMEOUT_MS * 1000};
  setsockopt(s, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
  s_sock = s;
  ESP_LOGI(TAG, "UDP port %d <-> ground station %s:%d", CONFIG_RUMI_LOCAL_PORT, CONFIG_RUMI_GROUND_IP,
           CONFIG_RUMI_GROUND_PORT);
  return ESP_OK;
}

static void fatal(const char* what, esp_err_t err) {
  ESP_LOGE(TAG, "%s: %s; restarting in 5 s", what, esp_err_to_name(err));
  vTaskDelay(pdMS_TO_TICKS(5000));
  esp_restart();
}

/* The HELLO nonce: the hardware RNG (true random while Wi-Fi runs). */
static int hw_random(void* ctx, uint8_t* out, size_t n) {
  (void)ctx;
  esp_fill_random(out, n);
  return 0;
}

/* The link key from NVS (namespace "rumi", blob "link_key", 32 bytes;
 * `rumi link keygen` writes the CSV that is flashed there). Without one the
 * robot refuses to stream unless the build says insecure. */
static int load_link_key(uint8_t key[RL_KEY_SIZE]) {
  nvs_handle_t h;
  size_t len = RL_KEY_SIZE;
  esp_err_t err = nvs_open("rumi", NVS_READONLY, &h);
  if (err == ESP_OK) {
    err = nvs_get_blob(h, "link_key", key, &len);
    nvs_close(h);
  }
  if (err == ESP_OK && len == RL_KEY_SIZE) return 1;
  ESP_LOGW(TAG, "no link key in NVS (rumi/link_key): %s", err == ESP_OK ? "wrong size" : esp_err_to_name(err));
  return 0;
}

void app_main(void) {
  esp_err_t err = nvs_flash_init(); /* the Wi-Fi driver keeps its calibration there */
  if (err == ESP_ERR_NVS_NO_FREE_PAGES || err == ESP_ERR_NVS_NEW_VERSION_FOUND) {
    ESP_ERROR_CHECK(nvs_flash_erase());
    err = nvs_flash_init();
  }
  if (err != ESP_OK) fatal("nvs_flash_init", err);

  s_lock = xSemaphoreCreateMutex();
  s_robot = (rr_robot*)heap_caps_malloc(sizeof(rr_robot), MALLOC_CAP_SPIRAM | MALLOC_CAP_8BIT);
  if (!s_lock || !s_robot) fatal("rr_robot in PSRAM (is PSRAM enabled and present?)", ESP_ERR_NO_MEM);
  ESP_LOGI(TAG, "rr_robot: %u bytes in PSRAM (%d frames of up to %u bytes kept for NACKs)",
           (unsigned)sizeof(rr_robot), RR_KEEP_FRAMES, (unsigned)RR_FRAME_CAP);

  /* Servos first: a defined neutral stance before anything else runs. */
  err = servo_gait_start();
  if (err != ESP_OK) ESP_LOGE(TAG, "servos unavailable: %s", esp_err_to_name(err));

  err = wifi_sta_start((uint16_t)CONFIG_RUMI_ROBOT_ID);
  if (err != ESP_OK) fatal("wifi_sta_start", err);

  s_cam.size = camera_boot_framesize();
  s_cam.quality = CONFIG_RUMI_JPEG_QUALITY;
  s_cam.interval_us = 1000000u / CONFIG_RUMI_FPS;
  s_cam.ok = camera_start(s_cam.size, s_cam.quality) == ESP_OK;
  if (!s_cam.ok) ESP_LOGE(TAG, "no camera: streaming IMU and heartbeats only");

  err = link_open();
  if (err != ESP_OK) fatal("UDP socket", err);

  rr_config cfg;
  rr_config_default(&cfg);
  cfg.robot_id = (uint16_t)CONFIG_RUMI_ROBOT_ID;
  cfg.heartbeat_ms = CONFIG_RUMI_HEARTBEAT_MS;
  cfg.failsafe_ms = CONFIG_RUMI_FAILSAFE_MS;
  cfg.imu_batch = CONFIG_RUMI_IMU_BATCH;
  cfg.imu_batch_ms = CONFIG_RUMI_IMU_BATCH_MS;
  cfg.gait = 1;
  cfg.has_key = load_link_key(cfg.key);
  if (!cfg.has_key) {
#ifdef CONFIG_RUMI_LINK_INSECURE
    ESP_LOGW(TAG, "INSECURE link (CONFIG_RUMI_LINK_INSECURE): anyone on the Wi-Fi can halt or steer this robot");
#else
    ESP_LOGE(TAG, "no link key: flash one (rumi link keygen; firmware/README.md) or build with "
                  "CONFIG_RUMI_LINK_INSECURE for a lab; standing still");
    for (;;) vTaskDelay(pdMS_TO_TICKS(1000));
#endif
  }
#ifdef CONFIG_RUMI_START_HALTED
  cfg.start_halted = 1;
#else
  cfg.start_halted = 0;
#endif
  const rr_hw hw = {
      .ctx = NULL,
      .send = hw_send,
      .now_us = hw_now_us,
      .set_motion = hw_set_motion,
      .set_camera = s_cam.ok ? hw_set_camera : NULL, /* NULL: camera commands are acked "unsupported" */
      .rssi_dbm = hw_rssi_dbm,
      .random = hw_random,
  };
  robot_lock();
  rr_init(s_robot, &hw, &cfg);
  robot_unlock();

  /* The IMU task is created before its timer, which notifies it. */
  if (xTaskCreatePinnedToCore(imu_task, "rr_imu", 6144, NULL, 7, &s_imu_task, 1) != pdPASS ||
      xTaskCreatePinnedToCore(rx_task, "rr_rx", 6144, NULL, 6, NULL, 0) != pdPASS ||
      xTaskCreatePinnedToCore(poll_task, "rr_poll", 6144, NULL, 6, NULL, 0) != pdPASS ||
      (s_cam.ok && xTaskCreatePinnedToCore(camera_task, "rr_camera", 6144, NULL, 5, NULL, 1) != pdPASS)) {
    fatal("task creation", ESP_ERR_NO_MEM);
  }
  const esp_timer_create_args_t targs = {
      .callback = imu_tick,
      .arg = NULL,
      .dispatch_method = ESP_TIMER_TASK,
      .name = "imu",
  };
  esp_timer_handle_t imu_timer;
  err = esp_timer_create(&targs, &imu_timer);
  if (err == ESP_OK) err = esp_timer_start_periodic(imu_timer, 1000000ULL / CONFIG_RUMI_IMU_RATE_HZ);
  if (err != ESP_OK) fatal("IMU timer", err);

  ESP_LOGI(TAG, "robot %d up (%s link): %s, %d fps, IMU %d Hz, fail-safe %d ms", CONFIG_RUMI_ROBOT_ID,
           cfg.has_key ? "authenticated" : "INSECURE",
           cfg.start_halted ? "halted until the ground station resumes it" : "walking once the ground station is heard", CONFIG_RUMI_FPS,
           CONFIG_RUMI_IMU_RATE_HZ, CONFIG_RUMI_FAILSAFE_MS);
}
