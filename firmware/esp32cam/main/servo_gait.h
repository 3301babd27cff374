/* Hobby servos on LEDC PWM (50 Hz, 0.5..2.5 ms) and a small gait table:
 * walking plays a gait's key poses in a loop, halting holds the neutral
 * stance (every servo at its centre). */
#pragma once

#include "esp_err.h"

/* Configures the LEDC timer and a channel per servo GPIO (menuconfig; -1 =
 * none), puts every servo in the neutral stance and starts the 50 Hz gait
 * timer. */
esp_err_t servo_gait_start(void);

/* Walk with this gait (moving = 1) or stand still (moving = 0). Any task;
 * takes effect at the next 20 ms servo update. Gaits: 0 stand, 1 walk,
 * 2 creep; others walk. */
void servo_gait_set(int moving, int gait);
