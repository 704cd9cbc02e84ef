/* SE(2) poses [x, y, theta]: angle wrapping, group operations, exp/log, boxplus and edge error. */
#include <pgem/geometry.h>

#include <math.h>

#define PGEM_PI 3.14159265358979323846
#define PGEM_TWO_PI (2.0 * PGEM_PI)

/* Below this |angle| the exp/log coefficients use Taylor series (truncation error < 1e-20). */
#define SMALL_ANGLE 1e-3

double pgem_wrap_angle(double angle) {
    /* fmod is exact, and so are the +-2pi corrections (Sterbenz), so no boundary drift. */
    double wrapped = fmod(angle, PGEM_TWO_PI);
    if (wrapped > PGEM_PI) {
        wrapped -= PGEM_TWO_PI;
    } else if (wrapped <= -PGEM_PI) {
        wrapped += PGEM_TWO_PI;
    }
    return wrapped;
}

/* out = R(theta) v; out may alias v. */
static void rotate2(double theta, const double v[2], double out[2]) {
    const double c = cos(theta), s = sin(theta);
    const double x = c * v[0] - s * v[1];
    const double y = s * v[0] + c * v[1];
    out[0] = x;
    out[1] = y;
}

void pgem_se2_compose(const double a[3], const double b[3], double out[3]) {
    double moved[2];
    const double theta = pgem_wrap_angle(a[2] + b[2]);
    rotate2(a[2], b, moved);
    out[0] = a[0] + moved[0];
    out[1] = a[1] + moved[1];
    out[2] = theta;
}

void pgem_se2_inverse(const double a[3], double out[3]) {
    const double minus_t[2] = {-a[0], -a[1]};
    const double theta = a[2];
    rotate2(-theta, minus_t, out);
    out[2] = pgem_wrap_angle(-theta);
}

void pgem_se2_between(const double a[3], const double b[3], double out[3]) {
    const double delta[2] = {b[0] - a[0], b[1] - a[1]};
    const double theta = pgem_wrap_angle(b[2] - a[2]);
    rotate2(-a[2], delta, out);
    out[2] = theta;
}

/* sin(w)/w and (1 - cos(w))/w, the entries of the SE(2) V matrix. */
static void se2_v_coefficients(double w, double *sin_over_w, double *one_minus_cos_over_w) {
    if (fabs(w) < SMALL_ANGLE) {
        const double w2 = w * w;
        *sin_over_w = 1.0 - w2 / 6.0 * (1.0 - w2 / 20.0);
        *one_minus_cos_over_w = w / 2.0 * (1.0 - w2 / 12.0 * (1.0 - w2 / 30.0));
    } else {
        const double half_sin = sin(0.5 * w);
        *sin_over_w = sin(w) / w;
        *one_minus_cos_over_w = 2.0 * half_sin * half_sin / w;
    }
}

/* (w/2) cot(w/2), the diagonal of V^-1 (its off-diagonal is +-w/2). */
static double half_angle_cot(double w) {
    const double half = 0.5 * w;
    if (fabs(w) < SMALL_ANGLE) {
        const double w2 = w * w;
        return 1.0 - w2 / 12.0 * (1.0 + w2 / 60.0);
    }
    return half * cos(half) / sin(half);
}

void pgem_se2_exp(const double tangent[3], double out[3]) {
    double a, b;
    const double u = tangent[0], v = tangent[1], w = tangent[2];
    se2_v_coefficients(w, &a, &b);
    out[0] = a * u - b * v;
    out[1] = b * u + a * v;
    out[2] = pgem_wrap_angle(w);
}

void pgem_se2_log(const double pose[3], double tangent[3]) {
    const double w = pgem_wrap_angle(pose[2]);
    const double diag = half_angle_cot(w), off = 0.5 * w;
    const double x = pose[0], y = pose[1];
    tangent[0] = diag * x + off * y;
    tangent[1] = -off * x + diag * y;
    tangent[2] = w;
}

void pgem_se2_boxplus(const double x[3], const double delta[3], double out[3]) {
    out[0] = x[0] + delta[0];
    out[1] = x[1] + delta[1];
    out[2] = pgem_wrap_angle(x[2] + delta[2]);
}

/* Row-major 3x3 Jacobians from the pieces of the error (see pgem_se2_error). linalg/assemble.c
 * relies on their form (the rotation entries, the ones and the zeros): keep the two in step. */
static void se2_error_jacobians(double theta_i, double theta_z, const double local[2],
                                double jacobian_i[9], double jacobian_j[9]) {
    /* e_t = Rz^T Ri^T (tj - ti) - Rz^T tz, e_theta = theta_j - theta_i - theta_z. */
    const double angle = -(theta_i + theta_z);
    const double c = cos(angle), s = sin(angle);
    double dtheta[2]; /* d e_t / d theta_i = Rz^T * d(Ri^T)/d theta_i (tj - ti) */
    const double perp[2] = {local[1], -local[0]};
    rotate2(-theta_z, perp, dtheta);
    if (jacobian_j) {
        const double jj[9] = {c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0};
        for (int k = 0; k < 9; ++k) {
            jacobian_j[k] = jj[k];
        }
    }
    if (jacobian_i) {
        const double ji[9] = {-c, s, dtheta[0], -s, -c, dtheta[1], 0.0, 0.0, -1.0};
        for (int k = 0; k < 9; ++k) {
            jacobian_i[k] = ji[k];
        }
    }
}

void pgem_se2_error(const double xi[3], const double xj[3], const double z[3], double e[3],
                    double jacobian_i[9], double jacobian_j[9]) {
    const double theta_i = xi[2], theta_z = z[2];
    const double delta[2] = {xj[0] - xi[0], xj[1] - xi[1]};
    const double angle = pgem_wrap_angle(xj[2] - theta_i - theta_z);
    double local[2]; /* Ri^T (tj - ti): translation of Xi^-1 Xj */
    double offset[2];
    rotate2(-theta_i, delta, local);
    offset[0] = local[0] - z[0];
    offset[1] = local[1] - z[1];
    if (jacobian_i || jacobian_j) { /* chi2-only callers (E-steps, LM trials) skip the trig */
        se2_error_jacobians(theta_i, theta_z, local, jacobian_i, jacobian_j);
    }
    rotate2(-theta_z, offset, e);
    e[2] = angle;
}
