/* The OV2640 through espressif/esp32-camera: JPEG, frame buffers in PSRAM,
 * always the latest frame. */
#pragma once

#include "esp_camera.h"
#include "esp_err.h"

/* Frame size and JPEG quality at boot (menuconfig). */
framesize_t camera_boot_framesize(void);

/* Starts the driver with the AI-Thinker pin map, then applies size/quality. */
esp_err_t camera_start(framesize_t size, int quality);

/* The sizes the ground station may ask for: QQVGA 160x120, QVGA 320x240,
 * CIF 400x296, VGA 640x480, SVGA 800x600. 0 and *out set, or -1. */
int camera_framesize_for(int width, int height, framesize_t* out);

/* Applies a frame size and a JPEG quality (1..63) to the sensor; 0 or -1. */
int camera_apply(framesize_t size, int quality);
