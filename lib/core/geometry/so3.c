/* Unit quaternions [qx, qy, qz, qw]: normalise, multiply, rotate, to matrix, SO(3) exp/log. */
#include <pgem/geometry.h>

#include <math.h>

/* Below this angle (or vector norm) exp/log use Taylor series (truncation error < 1e-20). */
#define SMALL_ANGLE 1e-3

double pgem_quat_normalize(double q[4]) {
    const double norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    if (norm > 0.0) {
        for (int k = 0; k < 4; ++k) {
            q[k] /= norm;
        }
    }
    return norm;
}

void pgem_quat_multiply(const double a[4], const double b[4], double out[4]) {
    const double x = a[3] * b[0] + a[0] * b[3] + a[1] * b[2] - a[2] * b[1];
    const double y = a[3] * b[1] + a[1] * b[3] + a[2] * b[0] - a[0] * b[2];
    const double z = a[3] * b[2] + a[2] * b[3] + a[0] * b[1] - a[1] * b[0];
    const double w = a[3] * b[3] - a[0] * b[0] - a[1] * b[1] - a[2] * b[2];
    out[0] = x;
    out[1] = y;
    out[2] = z;
    out[3] = w;
}

void pgem_quat_rotate(const double q[4], const double v[3], double out[3]) {
    /* v' = v + w t + u x t with u = vec(q), t = 2 u x v. */
    const double tx = 2.0 * (q[1] * v[2] - q[2] * v[1]);
    const double ty = 2.0 * (q[2] * v[0] - q[0] * v[2]);
    const double tz = 2.0 * (q[0] * v[1] - q[1] * v[0]);
    const double x = v[0] + q[3] * tx + (q[1] * tz - q[2] * ty);
    const double y = v[1] + q[3] * ty + (q[2] * tx - q[0] * tz);
    const double z = v[2] + q[3] * tz + (q[0] * ty - q[1] * tx);
    out[0] = x;
    out[1] = y;
    out[2] = z;
}

void pgem_quat_to_matrix(const double q[4], double rotation[9]) {
    const double x = q[0], y = q[1], z = q[2], w = q[3];
    rotation[0] = 1.0 - 2.0 * (y * y + z * z);
    rotation[1] = 2.0 * (x * y - w * z);
    rotation[2] = 2.0 * (x * z + w * y);
    rotation[3] = 2.0 * (x * y + w * z);
    rotation[4] = 1.0 - 2.0 * (x * x + z * z);
    rotation[5] = 2.0 * (y * z - w * x);
    rotation[6] = 2.0 * (x * z - w * y);
    rotation[7] = 2.0 * (y * z + w * x);
    rotation[8] = 1.0 - 2.0 * (x * x + y * y);
}

void pgem_so3_exp(const double phi[3], double q[4]) {
    const double angle = sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]);
    double scale; /* sin(angle / 2) / angle */
    double w;
    if (angle < SMALL_ANGLE) {
        const double a2 = angle * angle;
        scale = 0.5 * (1.0 - a2 / 24.0 * (1.0 - a2 / 80.0));
        w = 1.0 - a2 / 8.0 * (1.0 - a2 / 48.0);
    } else {
        scale = sin(0.5 * angle) / angle;
        w = cos(0.5 * angle);
    }
    q[0] = scale * phi[0];
    q[1] = scale * phi[1];
    q[2] = scale * phi[2];
    q[3] = w;
}

void pgem_so3_log(const double q[4], double phi[3]) {
    /* Use the w >= 0 representative so the angle 2 atan2(|v|, w) lies in [0, pi]. */
    const double sign = q[3] < 0.0 ? -1.0 : 1.0;
    const double w = sign * q[3];
    const double vec_norm = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
    double scale; /* angle / |v|; atan2 makes this independent of |q| */
    if (vec_norm == 0.0) {
        scale = 0.0;
    } else if (vec_norm < SMALL_ANGLE * w) {
        const double r2 = (vec_norm / w) * (vec_norm / w);
        scale = 2.0 / w * (1.0 - r2 / 3.0 * (1.0 - 0.6 * r2));
    } else {
        scale = 2.0 * atan2(vec_norm, w) / vec_norm;
    }
    scale *= sign;
    phi[0] = scale * q[0];
    phi[1] = scale * q[1];
    phi[2] = scale * q[2];
}
