/* Replays a recorded closed-loop run through the C ABI: the measurements and references
   of every update go in, the commands must match the f32 runner's. Written by
   `twip export`; run with `make check`. */
#include <math.h>
#include <stdio.h>

#include "replay_data.h"
#include "twip_config.h"

int main(void) {
    static TWIP_STATE state;
    if (twip_abi_version() != TWIP_ABI_VERSION) {
        printf("%s: twip.h is the C ABI's version %d, the library's is %d: export again with the twip the library is "
               "built from\n", TWIP_FAMILY, TWIP_ABI_VERSION, (int)twip_abi_version());
        return 2;
    }
    TwipStatus status = TWIP_INIT(&state, &twip_controller_config);
    if (status != TWIP_OK) {
        printf("%s: init failed: %s\n", TWIP_FAMILY, twip_status_text(status));
        return 2;
    }
    double worst = 0.0, largest = 0.0;
    int at = 0;
    for (int i = 0; i < replay_n; ++i) {
        TWIP_REFERENCE reference;
        const float *r = replay_ref[i];
        float *fields = (float *)&reference;
        for (unsigned k = 0; k < sizeof reference / sizeof(float); ++k) {
            fields[k] = r[k];
        }
        float u[TWIP_NU];
        status = TWIP_UPDATE(&state, replay_t[i], replay_y[i], &reference, u);
        if (status != TWIP_OK) {
            printf("%s: update %d at t = %g s failed: %s\n", TWIP_FAMILY, i, replay_t[i], twip_status_text(status));
            return 2;
        }
        for (int k = 0; k < TWIP_NU; ++k) {
            double d = fabs((double)u[k] - (double)replay_u[i][k]);
            if (d > worst) {
                worst = d;
                at = i;
            }
            if (fabs((double)replay_u[i][k]) > largest) {
                largest = fabs((double)replay_u[i][k]);
            }
        }
    }
    double relative = largest > 0.0 ? worst / largest : worst;
    printf("%s: %d updates replayed; largest difference %.3g (at update %d), %.3g of the largest command %.4g\n",
           TWIP_FAMILY, replay_n, worst, at, relative, largest);
    return relative <= @TOLERANCE@ ? 0 : 1;
}
