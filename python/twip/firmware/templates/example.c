/* An Arduino-style firmware loop around the exported controller. Written by `twip export`.
   Replace the board functions below with your drivers; on the host, `make example`
   builds it with a main() that runs the loop on a robot standing still.
   Safety: beyond TILT_CUTOFF_RAD the robot has fallen and the motors are killed until a
   reset (a robot on its side must not spin its wheels); a fault halts with the motors off. */
#include <stdint.h>
#include <math.h>

#include "twip_config.h"

/* The pitch beyond which the robot has fallen [rad]. */
#define TILT_CUTOFF_RAD (45.0f * TWIP_RAD_PER_DEG)

/* For identification (docs/sysid.md, "A dither on the command"): ± this current [A] added to
   the command, its sign drawn anew every period; about a third of the driver's current limit.
   Log the dithered command. 0 for normal running (or build with -DDITHER_AMPS=0.8f). */
#ifndef DITHER_AMPS
#define DITHER_AMPS 0.0f
#endif

/* ---- the board: replace these ---------------------------------------------------- */
static void read_imu(float accel[3], float gyro_dps[3]) {
    /* The sensor's own x, y, z: specific force (any unit) and rate (degrees per second).
       Which axis points where is the robot file's [sensors] (TWIP_IMU_* in twip_config.h). */
    accel[0] = 0.0f;
    accel[1] = 0.0f;
    accel[2] = 9.81f;
    gyro_dps[0] = gyro_dps[1] = gyro_dps[2] = 0.0f;
}
static void read_encoders(int32_t *right, int32_t *left) {
    /* Running 32-bit counts of each wheel relative to the body. A 16-bit timer counter
       must be extended here: total += (int16_t)(hw - last_hw); last_hw = hw; */
    *right = 0;
    *left = 0;
}
/* One motor's H-bridge as an L298 or TB6612 has it: a direction pin and a PWM duty pin
   (0..TWIP_PWM_MAX). motor 0 is the right, 1 the left. */
static void set_motor(int motor, int forward, uint16_t duty) {
    (void)motor; /* digitalWrite(DIR_PIN[motor], forward); analogWrite(PWM_PIN[motor], duty); */
    (void)forward;
    (void)duty;
}
/* ----------------------------------------------------------------------------------- */

static void motors_off(void) {
    set_motor(0, 1, 0);
    set_motor(1, 1, 0);
}

/* A signed duty [counts] onto a motor's direction and duty pins. A NaN duty is no command:
   the motor stops (the clamp below would read it as full power, and its sign as reverse). */
static void drive(int motor, float duty) {
    if (isnan(duty)) {
        set_motor(motor, 1, 0);
        return;
    }
    float magnitude = fabsf(duty);
    if (magnitude > (float)TWIP_PWM_MAX) magnitude = (float)TWIP_PWM_MAX;
    set_motor(motor, duty >= 0.0f, (uint16_t)magnitude);
}

/* A fault (a configuration the library refused): motors off, and stay here. On a board,
   blink an LED with `status` (twip_status_text(status) names it on the host). */
static volatile TwipStatus fault;
static void halt(TwipStatus status) {
    motors_off();
    fault = status;
    for (;;) {
    }
}

static TWIP_STATE controller;
static TwipTilt tilt;
static TwipEncoder encoder_right, encoder_left;
static TwipPwm pwm;
static uint32_t ticks; /* loop periods since setup(): time kept exactly, never a growing float */
static int killed;     /* the robot fell: motors off until reset */
#if TWIP_NX == 4
static uint32_t dither_bits = 2463534242u;

/* +1 or -1, drawn by a xorshift32 generator (identification fits the 2-DOF model). */
static float dither_sign(void) {
    dither_bits ^= dither_bits << 13;
    dither_bits ^= dither_bits >> 17;
    dither_bits ^= dither_bits << 5;
    return (dither_bits & 1u) ? 1.0f : -1.0f;
}
#endif

void setup(void) {
    TwipStatus s;
    motors_off();
    /* twip.h and the library of two C ABI versions disagree on every size: refuse to run. */
    if (twip_abi_version() != TWIP_ABI_VERSION) halt(TWIP_ERR_ABI);
    if ((s = TWIP_INIT(&controller, &twip_controller_config)) != TWIP_OK) halt(s);
    if ((s = twip_tilt_init(&tilt, &twip_tilt_config)) != TWIP_OK) halt(s);
    if ((s = twip_encoder_init(&encoder_right, twip_encoder_cpr)) != TWIP_OK) halt(s);
    if ((s = twip_encoder_init(&encoder_left, twip_encoder_cpr)) != TWIP_OK) halt(s);
    if ((s = twip_pwm_init(&pwm, &twip_pwm_config)) != TWIP_OK) halt(s);
    ticks = 0;
    killed = 0;
}

/* Call every TWIP_LOOP_PERIOD_S seconds (a timer interrupt, or a millis() check). */
void loop(void) {
    float accel[3], gyro_dps[3], phi, phi_dot;
    read_imu(accel, gyro_dps);
    float forward = TWIP_IMU_FORWARD_SIGN * accel[TWIP_IMU_FORWARD];
    float up = TWIP_IMU_UP_SIGN * accel[TWIP_IMU_UP];
    float pitch_rate = TWIP_IMU_PITCH_SIGN * gyro_dps[TWIP_IMU_PITCH] * TWIP_RAD_PER_DEG;
    twip_tilt_update(&tilt, twip_accel_tilt(forward, up), pitch_rate, TWIP_LOOP_PERIOD_S, &phi, &phi_dot);
    float t = (float)ticks * TWIP_LOOP_PERIOD_S;
    ticks++;
    if (killed || !(fabsf(phi) < TILT_CUTOFF_RAD)) { /* fallen (or a NaN pitch): motors off */
        killed = 1;
        motors_off();
        return;
    }
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
    float duty = 0.0f;
    if (TWIP_UPDATE(&controller, t, y, &reference, u) != TWIP_OK) {
        motors_off(); /* a bad measurement: no drive this period */
        return;
    }
    u[0] += DITHER_AMPS * dither_sign();
    if (twip_pwm_duty(&pwm, u[0], 0.5f * (beta_r_dot + beta_l_dot), &duty) != TWIP_OK) {
        motors_off();
        return;
    }
    drive(0, duty);
    drive(1, duty);
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
    float duty_r = 0.0f, duty_l = 0.0f;
    if (TWIP_UPDATE(&controller, t, y, &reference, u) != TWIP_OK ||
        twip_pwm_duty(&pwm, u[0], beta_r_dot, &duty_r) != TWIP_OK ||
        twip_pwm_duty(&pwm, u[1], beta_l_dot, &duty_l) != TWIP_OK) {
        motors_off();
        return;
    }
    drive(0, duty_r);
    drive(1, duty_l);
#endif
}

#ifdef TWIP_HOST_MAIN
#include <stdio.h>
int main(void) {
    setup();
    for (int i = 0; i < 200; ++i) {
        loop();
    }
    printf("example (%s): 200 loops of %g ms ran, %s\n", TWIP_FAMILY, TWIP_LOOP_PERIOD_S * 1e3,
           killed ? "the motors killed" : "upright");
    return killed;
}
#endif
