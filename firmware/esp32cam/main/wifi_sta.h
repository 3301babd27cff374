/* Wi-Fi station for the rumi robot: joins CONFIG_RUMI_WIFI_SSID and keeps
 * reconnecting, with exponential backoff, for as long as the robot runs. */
#pragma once

#include <stdbool.h>
#include <stdint.h>

#include "esp_err.h"

/* Starts the station (needs NVS initialised); returns at once, the connection
 * comes later. */
esp_err_t wifi_sta_start(uint16_t robot_id);

/* Associated and holding an IPv4 address. */
bool wifi_sta_connected(void);

/* Blocks up to timeout_ms for a connection; true if connected. */
bool wifi_sta_wait_connected(uint32_t timeout_ms);

/* RSSI of the access point in dBm, 0 when not connected. */
int wifi_sta_rssi(void);
