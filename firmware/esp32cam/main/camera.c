#include "camera.h"

#include "board.h"
#include "esp_log.h"
#include "sdkconfig.h"

static const char* TAG = "camera";

framesize_t camera_boot_framesize(void) {
#if defined(CONFIG_RUMI_FRAME_SIZE_QQVGA)
  return FRAMESIZE_QQVGA;
#elif defined(CONFIG_RUMI_FRAME_SIZE_CIF)
  return FRAMESIZE_CIF;
#elif defined(CONFIG_RUMI_FRAME_SIZE_VGA)
  return FRAMESIZE_VGA;
#elif defined(CONFIG_RUMI_FRAME_SIZE_SVGA)
  return FRAMESIZE_SVGA;
#else
  return FRAMESIZE_QVGA;
#endif
}

int camera_framesize_for(int width, int height, framesize_t* out) {
  static const struct {
    int w, h;
    framesize_t fs;
  } sizes[] = {
      {160, 120, FRAMESIZE_QQVGA}, {320, 240, FRAMESIZE_QVGA}, {400, 296, FRAMESIZE_CIF},
      {640, 480, FRAMESIZE_VGA},   {800, 600, FRAMESIZE_SVGA},
  };
  for (size_t i = 0; i < sizeof(sizes) / sizeof(sizes[0]); ++i) {
    if (sizes[i].w == width && sizes[i].h == height) {
      *out = sizes[i].fs;
      return 0;
    }
  }
  return -1;
}

esp_err_t camera_start(framesize_t size, int quality) {
  camera_config_t c = {
      .pin_pwdn = CAM_PIN_PWDN,
      .pin_reset = CAM_PIN_RESET,
      .pin_xclk = CAM_PIN_XCLK,
      .pin_sccb_sda = CAM_PIN_SIOD,
      .pin_sccb_scl = CAM_PIN_SIOC,
      .pin_d7 = CAM_PIN_D7,
      .pin_d6 = CAM_PIN_D6,
      .pin_d5 = CAM_PIN_D5,
      .pin_d4 = CAM_PIN_D4,
      .pin_d3 = CAM_PIN_D3,
      .pin_d2 = CAM_PIN_D2,
      .pin_d1 = CAM_PIN_D1,
      .pin_d0 = CAM_PIN_D0,
      .pin_vsync = CAM_PIN_VSYNC,
      .pin_href = CAM_PIN_HREF,
      .pin_pclk = CAM_PIN_PCLK,
      .xclk_freq_hz = CAM_XCLK_HZ,
      .ledc_timer = LEDC_TIMER_0,
      .ledc_channel = LEDC_CHANNEL_0,
      .pixel_format = PIXFORMAT_JPEG,
      /* The JPEG frame buffers are sized from the frame size at init: start
       * at the largest size the ground station may ask for (SVGA), so a
       * later switch up does not truncate frames, then go to the real one. */
      .frame_size = FRAMESIZE_SVGA,
      .jpeg_quality = quality,
      .fb_count = 2,
      .fb_location = CAMERA_FB_IN_PSRAM,
      .grab_mode = CAMERA_GRAB_LATEST,
      .sccb_i2c_port = 1, /* used only if pin_sccb_sda were -1 */
  };
  esp_err_t err = esp_camera_init(&c);
  if (err != ESP_OK) {
    ESP_LOGE(TAG, "esp_camera_init: %s (0x%x)", esp_err_to_name(err), (unsigned)err);
    return err;
  }
  sensor_t* s = esp_camera_sensor_get();
  if (!s) return ESP_FAIL;
  if (s->id.PID != OV2640_PID) ESP_LOGW(TAG, "sensor PID 0x%x is not an OV2640", (unsigned)s->id.PID);
#ifdef CONFIG_RUMI_CAMERA_VFLIP
  s->set_vflip(s, 1);
#endif
#ifdef CONFIG_RUMI_CAMERA_HMIRROR
  s->set_hmirror(s, 1);
#endif
  if (camera_apply(size, quality) != 0) return ESP_FAIL;
  ESP_LOGI(TAG, "OV2640 started: JPEG, frame size %d, quality %d", (int)size, quality);
  return ESP_OK;
}

int camera_apply(framesize_t size, int quality) {
  sensor_t* s = esp_camera_sensor_get();
  if (!s || quality < 1 || quality > 63) return -1;
  if (s->status.framesize != size && s->set_framesize(s, size) != 0) {
    ESP_LOGW(TAG, "set_framesize(%d) failed", (int)size);
    return -1;
  }
  if (s->status.quality != quality && s->set_quality(s, quality) != 0) {
    ESP_LOGW(TAG, "set_quality(%d) failed", quality);
    return -1;
  }
  return 0;
}
