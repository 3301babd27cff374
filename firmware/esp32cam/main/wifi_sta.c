#include "wifi_sta.h"

#include <stdio.h>
#include <string.h>

#include "esp_event.h"
#include "esp_log.h"
#include "esp_netif.h"
#include "esp_timer.h"
#include "esp_wifi.h"
#include "freertos/FreeRTOS.h"
#include "freertos/event_groups.h"
#include "sdkconfig.h"

static const char* TAG = "wifi";

#define CONNECTED_BIT BIT0
#define BACKOFF_MIN_MS 250u
#define BACKOFF_MAX_MS 8000u

static EventGroupHandle_t s_events;
static esp_timer_handle_t s_retry_timer;
/* Only touched from the default event loop task and the esp_timer task, one
 * event at a time; a stale read costs one backoff step at most. */
static volatile uint32_t s_backoff_ms = BACKOFF_MIN_MS;
static volatile uint32_t s_attempt;
static char s_hostname[24];

static void schedule_retry(void) {
  uint32_t delay_ms = s_backoff_ms;
  s_backoff_ms = delay_ms >= BACKOFF_MAX_MS / 2 ? BACKOFF_MAX_MS : delay_ms * 2;
  s_attempt = s_attempt + 1;
  ESP_LOGI(TAG, "reconnecting to \"%s\" in %u ms (attempt %u)", CONFIG_RUMI_WIFI_SSID, (unsigned)delay_ms,
           (unsigned)s_attempt);
  esp_timer_stop(s_retry_timer); /* ESP_ERR_INVALID_STATE when not armed: fine */
  esp_err_t err = esp_timer_start_once(s_retry_timer, (uint64_t)delay_ms * 1000u);
  if (err != ESP_OK) ESP_LOGE(TAG, "esp_timer_start_once: %s", esp_err_to_name(err));
}

/* esp_timer task: one connection attempt; its failure arrives as
 * WIFI_EVENT_STA_DISCONNECTED, which schedules the next one. */
static void retry_cb(void* arg) {
  (void)arg;
  esp_err_t err = esp_wifi_connect();
  if (err != ESP_OK) {
    ESP_LOGW(TAG, "esp_wifi_connect: %s", esp_err_to_name(err));
    schedule_retry(); /* no event will follow a refused attempt */
  }
}

static void on_event(void* arg, esp_event_base_t base, int32_t id, void* data) {
  (void)arg;
  if (base == WIFI_EVENT && id == WIFI_EVENT_STA_START) {
    esp_err_t err = esp_wifi_connect();
    if (err != ESP_OK) schedule_retry();
  } else if (base == WIFI_EVENT && id == WIFI_EVENT_STA_DISCONNECTED) {
    const wifi_event_sta_disconnected_t* d = (const wifi_event_sta_disconnected_t*)data;
    xEventGroupClearBits(s_events, CONNECTED_BIT);
    ESP_LOGW(TAG, "disconnected from \"%s\" (reason %d)", CONFIG_RUMI_WIFI_SSID, d ? (int)d->reason : -1);
    schedule_retry();
  } else if (base == IP_EVENT && id == IP_EVENT_STA_GOT_IP) {
    const ip_event_got_ip_t* e = (const ip_event_got_ip_t*)data;
    ESP_LOGI(TAG, "connected to \"%s\", address " IPSTR, CONFIG_RUMI_WIFI_SSID, IP2STR(&e->ip_info.ip));
    s_backoff_ms = BACKOFF_MIN_MS;
    s_attempt = 0;
    xEventGroupSetBits(s_events, CONNECTED_BIT);
  } else if (base == IP_EVENT && id == IP_EVENT_STA_LOST_IP) {
    ESP_LOGW(TAG, "lost the IPv4 address");
    xEventGroupClearBits(s_events, CONNECTED_BIT);
  }
}

esp_err_t wifi_sta_start(uint16_t robot_id) {
  s_events = xEventGroupCreate();
  if (!s_events) return ESP_ERR_NO_MEM;

  const esp_timer_create_args_t targs = {
      .callback = retry_cb,
      .arg = NULL,
      .dispatch_method = ESP_TIMER_TASK,
      .name = "wifi_retry",
  };
  esp_err_t err = esp_timer_create(&targs, &s_retry_timer);
  if (err != ESP_OK) return err;

  err = esp_netif_init();
  if (err != ESP_OK) return err;
  err = esp_event_loop_create_default();
  if (err != ESP_OK && err != ESP_ERR_INVALID_STATE) return err; /* already created: fine */
  esp_netif_t* netif = esp_netif_create_default_wifi_sta();
  if (!netif) return ESP_FAIL;
  snprintf(s_hostname, sizeof(s_hostname), "rumi-robot-%u", (unsigned)robot_id);
  esp_netif_set_hostname(netif, s_hostname);

  wifi_init_config_t init = WIFI_INIT_CONFIG_DEFAULT();
  err = esp_wifi_init(&init);
  if (err != ESP_OK) return err;
  err = esp_event_handler_instance_register(WIFI_EVENT, ESP_EVENT_ANY_ID, on_event, NULL, NULL);
  if (err != ESP_OK) return err;
  err = esp_event_handler_instance_register(IP_EVENT, IP_EVENT_STA_GOT_IP, on_event, NULL, NULL);
  if (err != ESP_OK) return err;
  err = esp_event_handler_instance_register(IP_EVENT, IP_EVENT_STA_LOST_IP, on_event, NULL, NULL);
  if (err != ESP_OK) return err;

  /* The credentials come from menuconfig, not from what NVS remembers. */
  err = esp_wifi_set_storage(WIFI_STORAGE_RAM);
  if (err != ESP_OK) return err;
  wifi_config_t wc;
  memset(&wc, 0, sizeof(wc));
  const char* ssid = CONFIG_RUMI_WIFI_SSID;
  const char* pass = CONFIG_RUMI_WIFI_PASSWORD;
  size_t n = strlen(ssid);
  memcpy(wc.sta.ssid, ssid, n < sizeof(wc.sta.ssid) ? n : sizeof(wc.sta.ssid));
  n = strlen(pass);
  memcpy(wc.sta.password, pass, n < sizeof(wc.sta.password) ? n : sizeof(wc.sta.password));
  wc.sta.threshold.authmode = pass[0] ? WIFI_AUTH_WPA2_PSK : WIFI_AUTH_OPEN;
  wc.sta.scan_method = WIFI_ALL_CHANNEL_SCAN;
  wc.sta.sort_method = WIFI_CONNECT_AP_BY_SIGNAL;

  err = esp_wifi_set_mode(WIFI_MODE_STA);
  if (err != ESP_OK) return err;
  err = esp_wifi_set_config(WIFI_IF_STA, &wc);
  if (err != ESP_OK) return err;
  err = esp_wifi_start();
  if (err != ESP_OK) return err;
  /* Streaming: no modem sleep (it adds up to a beacon interval of latency to
   * every control and NACK the ground station sends). */
  esp_wifi_set_ps(WIFI_PS_NONE);
  ESP_LOGI(TAG, "station started as %s, joining \"%s\"", s_hostname, CONFIG_RUMI_WIFI_SSID);
  return ESP_OK;
}

bool wifi_sta_connected(void) {
  return s_events && (xEventGroupGetBits(s_events) & CONNECTED_BIT) != 0;
}

bool wifi_sta_wait_connected(uint32_t timeout_ms) {
  if (!s_events) return false;
  EventBits_t bits = xEventGroupWaitBits(s_events, CONNECTED_BIT, pdFALSE, pdTRUE, pdMS_TO_TICKS(timeout_ms));
  return (bits & CONNECTED_BIT) != 0;
}

int wifi_sta_rssi(void) {
  wifi_ap_record_t ap;
  if (!wifi_sta_connected() || esp_wifi_sta_get_ap_info(&ap) != ESP_OK) return 0;
  return ap.rssi;
}
