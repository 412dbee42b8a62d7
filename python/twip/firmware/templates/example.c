/* An Arduino-style firmware loop around the exported controller. Written by `twip export`.
   Replace the four board functions below with your drivers; on the host, `make example`
   builds it with a main() that runs the loop on a robot standing still. */
#include <stdint.h>
#include <math.h>
#include <stdio.h>

#include "twip_config.h"

/* ---- the board: replace these ---------------------------------------------------- */
static void read_imu(float *accel_x, float *accel_z, float *gyro_dps) {
    *accel_x = 0.0f; /* specific force along the body's forward axis, any unit */
    *accel_z = 9.81f; /* along the body's axis, up */
    *gyro_dps = 0.0f; /* pitch rate, degrees per second */
}
static void read_encoders(int32_t *right, int32_t *left) {
    /* Running 32-bit counts of each wheel relative to the body. A 16-bit timer counter
       must be extended here: total += (int16_t)(hw - last_hw); last_hw = hw; */
    *right = 0;
    *left = 0;
}
static void write_pwm(float right, float left) {
    (void)right; /* duties in PWM counts, within +-pwm_max */
    (void)left;
}
static void halt(const char *what, TwipStatus status) {
    printf("%s: %s\n", what, twip_status_text(status));
    for (;;) {
    }
}
/* ----------------------------------------------------------------------------------- */

static TWIP_STATE controller;
static TwipTilt tilt;
static TwipEncoder encoder_right, encoder_left;
static TwipPwm pwm;
static float t;

void setup(void) {
    TwipStatus s;
    if ((s = TWIP_INIT(&controller, &twip_controller_config)) != TWIP_OK) halt("controller", s);
    if ((s = twip_tilt_init(&tilt, &twip_tilt_config)) != TWIP_OK) halt("tilt filter", s);
    if ((s = twip_encoder_init(&encoder_right, twip_encoder_cpr)) != TWIP_OK) halt("encoder", s);
    if ((s = twip_encoder_init(&encoder_left, twip_encoder_cpr)) != TWIP_OK) halt("encoder", s);
    if ((s = twip_pwm_init(&pwm, &twip_pwm_config)) != TWIP_OK) halt("pwm", s);
}

/* Call every TWIP_LOOP_PERIOD_S seconds (a timer interrupt, or a millis() check). */
void loop(void) {
    float ax, az, gyro_dps, phi, phi_dot;
    read_imu(&ax, &az, &gyro_dps);
    twip_tilt_update(&tilt, twip_accel_tilt(ax, az), gyro_dps * TWIP_RAD_PER_DEG, TWIP_LOOP_PERIOD_S, &phi, &phi_dot);
    int32_t count_right, count_left;
    read_encoders(&count_right, &count_left);
    float beta_r, beta_r_dot, beta_l, beta_l_dot; /* wheels relative to the body */
    twip_encoder_read(&encoder_right, count_right, TWIP_LOOP_PERIOD_S, &beta_r, &beta_r_dot);
    twip_encoder_read(&encoder_left, count_left, TWIP_LOOP_PERIOD_S, &beta_l, &beta_l_dot);
#if TWIP_NX == 4
    /* 2-DOF: the wheel angle is the encoders' mean plus the pitch (the motors ride the body). */
    float y[4] = {phi, phi_dot, 0.5f * (beta_r + beta_l) + phi, 0.5f * (beta_r_dot + beta_l_dot) + phi_dot};
    TwipSpeedRef reference = {0.0f, 0.0f}; /* stand still; set theta_dot to drive */
    float u[1];
    if (TWIP_UPDATE(&controller, t, y, &reference, u) == TWIP_OK) {
        float duty;
        twip_pwm_duty(&pwm, u[0], 0.5f * (beta_r_dot + beta_l_dot), &duty);
        write_pwm(duty, duty);
    }
#else
    /* 3-DOF: odometry from the wheels' absolute speeds. */
    static float x, y_pos, psi;
    float right = beta_r_dot + phi_dot, left = beta_l_dot + phi_dot;
    float v = 0.5f * TWIP_WHEEL_RADIUS * (right + left);
    float omega = 0.5f * TWIP_WHEEL_RADIUS / TWIP_HALF_TRACK * (right - left);
    psi += omega * TWIP_LOOP_PERIOD_S;
    x += v * cosf(psi) * TWIP_LOOP_PERIOD_S;
    y_pos += v * sinf(psi) * TWIP_LOOP_PERIOD_S;
    float y[7] = {x, y_pos, psi, phi, phi_dot, v, omega};
    TwipPlanarRef reference = {0}; /* hold the start pose; feed your trajectory here */
    float u[2];
    if (TWIP_UPDATE(&controller, t, y, &reference, u) == TWIP_OK) {
        float duty_r, duty_l;
        twip_pwm_duty(&pwm, u[0], beta_r_dot, &duty_r);
        twip_pwm_duty(&pwm, u[1], beta_l_dot, &duty_l);
        write_pwm(duty_r, duty_l);
    }
#endif
    t += TWIP_LOOP_PERIOD_S;
}

#ifdef TWIP_HOST_MAIN
int main(void) {
    setup();
    for (int i = 0; i < 200; ++i) {
        loop();
    }
    printf("example (%s): 200 loops of %g ms ran\n", TWIP_FAMILY, TWIP_LOOP_PERIOD_S * 1e3);
    return 0;
}
#endif
