/* AI-Thinker ESP32-CAM pins.
 *
 * Taken by the board: the OV2640 (below), PSRAM (GPIO 16, 17), flash (6-11),
 * the console / flashing UART (GPIO 1 TX, 3 RX), GPIO 33 (red LED, not on
 * the header). Broken out and otherwise free: GPIO 2, 4, 12, 13, 14, 15, all
 * wired to the microSD slot, so the firmware uses no SD card.
 *
 *   GPIO 14  MPU6050 SDA  (SD CLK)
 *   GPIO 15  MPU6050 SCL  (SD CMD; strapping pin, high at boot = default)
 *   GPIO 13  servo 0      (SD D3)
 *   GPIO  2  servo 1      (SD D0; strapping pin: low/floating to flash)
 *   GPIO 12  spare        (SD D2; strapping pin: must be LOW at boot or the
 *                          flash gets 1.8 V and the chip does not boot)
 *   GPIO  4  spare        (SD D1; drives the white flash LED)
 * The IMU and servo pins are menuconfig settings (main/Kconfig.projbuild). */
#pragma once

#include "sdkconfig.h"

/* OV2640 on the AI-Thinker module (esp32-camera's "CAMERA_MODEL_AI_THINKER"). */
#define CAM_PIN_PWDN 32
#define CAM_PIN_RESET (-1) /* not wired: software reset */
#define CAM_PIN_XCLK 0
#define CAM_PIN_SIOD 26
#define CAM_PIN_SIOC 27
#define CAM_PIN_D7 35
#define CAM_PIN_D6 34
#define CAM_PIN_D5 39
#define CAM_PIN_D4 36
#define CAM_PIN_D3 21
#define CAM_PIN_D2 19
#define CAM_PIN_D1 18
#define CAM_PIN_D0 5
#define CAM_PIN_VSYNC 25
#define CAM_PIN_HREF 23
#define CAM_PIN_PCLK 22
#define CAM_XCLK_HZ 20000000

/* The camera's SCCB uses I2C port 1 (CONFIG_SCCB_HARDWARE_I2C_PORT1) and
 * LEDC low-speed timer 0 / channel 0 for XCLK; the IMU and the servos keep
 * clear of them. */
#define IMU_I2C_PORT 0
#define IMU_SDA_GPIO CONFIG_RUMI_IMU_SDA_GPIO
#define IMU_SCL_GPIO CONFIG_RUMI_IMU_SCL_GPIO

#define SERVO_MAX 4
#define SERVO_GPIOS \
  { CONFIG_RUMI_SERVO0_GPIO, CONFIG_RUMI_SERVO1_GPIO, CONFIG_RUMI_SERVO2_GPIO, CONFIG_RUMI_SERVO3_GPIO }
