#include "mpu6050.h"

#include "board.h"
#include "driver/i2c.h"
#include "esp_log.h"
#include "freertos/FreeRTOS.h"
#include "freertos/task.h"
#include "sdkconfig.h"

static const char* TAG = "mpu6050";

#ifdef CONFIG_RUMI_IMU_AD0_HIGH
#define MPU_ADDR 0x69
#else
#define MPU_ADDR 0x68
#endif

/* Register map (MPU-6000/6050 register map, rev 4.2). */
#define REG_SMPLRT_DIV 0x19
#define REG_CONFIG 0x1A
#define REG_GYRO_CONFIG 0x1B
#define REG_ACCEL_CONFIG 0x1C
#define REG_ACCEL_XOUT_H 0x3B /* 14 bytes: accel xyz, temperature, gyro xyz */
#define REG_SIGNAL_PATH_RESET 0x68
#define REG_PWR_MGMT_1 0x6B
#define REG_WHO_AM_I 0x75

#define GYRO_FS_500 0x08   /* FS_SEL 1: 65.5 LSB per deg/s */
#define ACCEL_FS_4G 0x08   /* AFS_SEL 1: 8192 LSB per g */
#define ACCEL_SCALE (9.80665f / 8192.0f)
#define GYRO_SCALE ((3.14159265358979f / 180.0f) / 65.5f)

#define I2C_TIMEOUT pdMS_TO_TICKS(10)

static int s_bus_ready;

static esp_err_t write_reg(uint8_t reg, uint8_t value) {
  const uint8_t b[2] = {reg, value};
  return i2c_master_write_to_device(IMU_I2C_PORT, MPU_ADDR, b, sizeof(b), I2C_TIMEOUT);
}

static esp_err_t read_regs(uint8_t reg, uint8_t* out, size_t n) {
  return i2c_master_write_read_device(IMU_I2C_PORT, MPU_ADDR, &reg, 1, out, n, I2C_TIMEOUT);
}

static esp_err_t bus_start(void) {
  if (s_bus_ready) return ESP_OK;
  i2c_config_t c = {
      .mode = I2C_MODE_MASTER,
      .sda_io_num = IMU_SDA_GPIO,
      .scl_io_num = IMU_SCL_GPIO,
      /* The GY-521 breakout has 4.7k pull-ups; the internal ones (~45k) only
       * help a bare chip. */
      .sda_pullup_en = GPIO_PULLUP_ENABLE,
      .scl_pullup_en = GPIO_PULLUP_ENABLE,
      .master.clk_speed = CONFIG_RUMI_IMU_I2C_HZ,
      .clk_flags = 0,
  };
  esp_err_t err = i2c_param_config(IMU_I2C_PORT, &c);
  if (err == ESP_OK) err = i2c_driver_install(IMU_I2C_PORT, I2C_MODE_MASTER, 0, 0, 0);
  if (err != ESP_OK) {
    ESP_LOGE(TAG, "I2C%d on SDA %d / SCL %d: %s", IMU_I2C_PORT, IMU_SDA_GPIO, IMU_SCL_GPIO, esp_err_to_name(err));
    return err;
  }
  s_bus_ready = 1;
  return ESP_OK;
}

esp_err_t mpu6050_start(uint32_t rate_hz) {
  esp_err_t err = bus_start();
  if (err != ESP_OK) return err;

  if (write_reg(REG_PWR_MGMT_1, 0x80) != ESP_OK) { /* device reset */
    ESP_LOGE(TAG, "no answer at 0x%02x (SDA GPIO %d, SCL GPIO %d)", MPU_ADDR, IMU_SDA_GPIO, IMU_SCL_GPIO);
    return ESP_ERR_NOT_FOUND;
  }
  vTaskDelay(pdMS_TO_TICKS(100));
  write_reg(REG_SIGNAL_PATH_RESET, 0x07);
  vTaskDelay(pdMS_TO_TICKS(100));

  uint8_t who = 0;
  err = read_regs(REG_WHO_AM_I, &who, 1);
  if (err != ESP_OK) return err;
  if (who != 0x68) ESP_LOGW(TAG, "WHO_AM_I 0x%02x, expected 0x68 (a clone or an MPU6500?)", who);

  if (rate_hz < 4) rate_hz = 4;
  if (rate_hz > 1000) rate_hz = 1000;
  /* DLPF on: gyro output at 1 kHz, divided by SMPLRT_DIV + 1. Bandwidth
   * 44 Hz (DLPF_CFG 3) up to 400 Hz reads, 94 Hz (DLPF_CFG 2) above. */
  const uint8_t div = (uint8_t)(1000u / rate_hz - 1u);
  const uint8_t dlpf = rate_hz >= 400 ? 2 : 3;
  err = write_reg(REG_PWR_MGMT_1, 0x01); /* awake, clock from the X gyro PLL */
  if (err == ESP_OK) err = write_reg(REG_CONFIG, dlpf);
  if (err == ESP_OK) err = write_reg(REG_SMPLRT_DIV, div);
  if (err == ESP_OK) err = write_reg(REG_GYRO_CONFIG, GYRO_FS_500);
  if (err == ESP_OK) err = write_reg(REG_ACCEL_CONFIG, ACCEL_FS_4G);
  if (err != ESP_OK) {
    ESP_LOGE(TAG, "configuration failed: %s", esp_err_to_name(err));
    return err;
  }
  vTaskDelay(pdMS_TO_TICKS(50)); /* gyro PLL and filters settle */
  ESP_LOGI(TAG, "MPU6050 at 0x%02x: %u Hz (sensor %u Hz), +-4 g, +-500 deg/s, DLPF_CFG %u", MPU_ADDR,
           (unsigned)rate_hz, (unsigned)(1000u / (div + 1u)), (unsigned)dlpf);
  return ESP_OK;
}

static int16_t be16(const uint8_t* p) { return (int16_t)((uint16_t)p[0] << 8 | p[1]); }

esp_err_t mpu6050_read(mpu6050_sample* out) {
  uint8_t b[14];
  esp_err_t err = read_regs(REG_ACCEL_XOUT_H, b, sizeof(b));
  if (err != ESP_OK) return err;
  for (int i = 0; i < 3; ++i) {
    out->accel[i] = (float)be16(b + 2 * i) * ACCEL_SCALE;
    out->gyro[i] = (float)be16(b + 8 + 2 * i) * GYRO_SCALE;
  }
  return ESP_OK;
}
