/* MPU6050 over I2C (legacy ESP-IDF I2C driver, port IMU_I2C_PORT):
 * accelerometer +-4 g, gyroscope +-500 deg/s, digital low-pass filter below
 * the Nyquist rate of the read rate. */
#pragma once

#include <stdint.h>

#include "esp_err.h"

typedef struct mpu6050_sample {
  float accel[3]; /* m/s^2, sensor axes */
  float gyro[3];  /* rad/s, sensor axes */
} mpu6050_sample;

/* Installs the I2C driver (once) and configures the sensor for rate_hz
 * samples per second; ESP_ERR_NOT_FOUND if nothing answers. */
esp_err_t mpu6050_start(uint32_t rate_hz);

/* Reads the latest sample (one 14-byte burst, about 0.4 ms at 400 kHz). */
esp_err_t mpu6050_read(mpu6050_sample* out);
