/* SE(3) poses [x, y, z, qx, qy, qz, qw]: group operations, exp/log, boxplus and edge error. */
#include <pgem/geometry.h>

#include <math.h>
#include <stddef.h>

/* Below this angle the V and V^-1 coefficients use Taylor series (truncation error < 1e-20). */
#define SMALL_ANGLE 1e-3

static void cross3(const double a[3], const double b[3], double out[3]) {
    const double x = a[1] * b[2] - a[2] * b[1];
    const double y = a[2] * b[0] - a[0] * b[2];
    const double z = a[0] * b[1] - a[1] * b[0];
    out[0] = x;
    out[1] = y;
    out[2] = z;
}

static void conjugate(const double q[4], double out[4]) {
    out[0] = -q[0];
    out[1] = -q[1];
    out[2] = -q[2];
    out[3] = q[3];
}

/* Writes translation and (normalised) rotation into a pose. */
static void store_pose(const double t[3], const double q[4], double out[7]) {
    double unit[4] = {q[0], q[1], q[2], q[3]};
    pgem_quat_normalize(unit);
    for (int k = 0; k < 3; ++k) {
        out[k] = t[k];
    }
    for (int k = 0; k < 4; ++k) {
        out[3 + k] = unit[k];
    }
}

void pgem_se3_compose(const double a[7], const double b[7], double out[7]) {
    double t[3], q[4];
    pgem_quat_rotate(a + 3, b, t);
    for (int k = 0; k < 3; ++k) {
        t[k] += a[k];
    }
    pgem_quat_multiply(a + 3, b + 3, q);
    store_pose(t, q, out);
}

void pgem_se3_inverse(const double a[7], double out[7]) {
    double q[4], t[3];
    const double minus_t[3] = {-a[0], -a[1], -a[2]};
    conjugate(a + 3, q);
    pgem_quat_rotate(q, minus_t, t);
    store_pose(t, q, out);
}

void pgem_se3_between(const double a[7], const double b[7], double out[7]) {
    double q_inv[4], q[4], t[3];
    const double delta[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    conjugate(a + 3, q_inv);
    pgem_quat_rotate(q_inv, delta, t);
    pgem_quat_multiply(q_inv, b + 3, q);
    store_pose(t, q, out);
}

/* V = I + b [phi]x + c [phi]x^2 with b = (1 - cos a) / a^2, c = (a - sin a) / a^3, a = |phi|. */
static void se3_v_coefficients(double angle, double *b, double *c) {
    const double a2 = angle * angle;
    if (angle < SMALL_ANGLE) {
        *b = 0.5 - a2 / 24.0 * (1.0 - a2 / 30.0);
        *c = 1.0 / 6.0 - a2 / 120.0 * (1.0 - a2 / 42.0);
    } else {
        const double half_sin = sin(0.5 * angle);
        *b = 2.0 * half_sin * half_sin / a2;
        *c = (angle - sin(angle)) / (a2 * angle);
    }
}

/* V^-1 = I - [phi]x / 2 + d [phi]x^2 with d = (1 - (a / 2) cot(a / 2)) / a^2, a = |phi|. */
static double se3_v_inverse_coefficient(double angle) {
    const double a2 = angle * angle;
    const double half = 0.5 * angle;
    if (angle < SMALL_ANGLE) {
        return 1.0 / 12.0 + a2 / 720.0 * (1.0 + a2 / 42.0);
    }
    return (1.0 - half * cos(half) / sin(half)) / a2;
}

/* out = v + b (phi x v) + c (phi x (phi x v)); out may alias v. */
static void apply_v_form(const double phi[3], double b, double c, const double v[3],
                         double out[3]) {
    double once[3], twice[3];
    cross3(phi, v, once);
    cross3(phi, once, twice);
    for (int k = 0; k < 3; ++k) {
        out[k] = v[k] + b * once[k] + c * twice[k];
    }
}

static double norm3(const double v[3]) {
    return sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

void pgem_se3_exp(const double tangent[6], double out[7]) {
    double b, c, t[3], q[4];
    const double phi[3] = {tangent[3], tangent[4], tangent[5]};
    se3_v_coefficients(norm3(phi), &b, &c);
    apply_v_form(phi, b, c, tangent, t);
    pgem_so3_exp(phi, q);
    store_pose(t, q, out);
}

void pgem_se3_log(const double pose[7], double tangent[6]) {
    double phi[3], rho[3];
    pgem_so3_log(pose + 3, phi);
    apply_v_form(phi, -0.5, se3_v_inverse_coefficient(norm3(phi)), pose, rho);
    for (int k = 0; k < 3; ++k) {
        tangent[k] = rho[k];
        tangent[3 + k] = phi[k];
    }
}

void pgem_se3_boxplus(const double x[7], const double delta[6], double out[7]) {
    double step[4], t[3], q[4];
    pgem_quat_rotate(x + 3, delta, t);
    for (int k = 0; k < 3; ++k) {
        t[k] += x[k];
    }
    pgem_so3_exp(delta + 3, step);
    pgem_quat_multiply(x + 3, step, q);
    store_pose(t, q, out);
}

/* Skew matrix [a]x (row-major), with [a]x b = a x b. */
static void skew(const double a[3], double out[9]) {
    out[0] = 0.0;
    out[1] = -a[2];
    out[2] = a[1];
    out[3] = a[2];
    out[4] = 0.0;
    out[5] = -a[0];
    out[6] = -a[1];
    out[7] = a[0];
    out[8] = 0.0;
}

/* out = a * b for row-major 3x3 matrices; out must not alias a or b. */
static void matmul3(const double a[9], const double b[9], double out[9]) {
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
            const double *row = a + (ptrdiff_t)r * 3;
            out[r * 3 + c] = row[0] * b[c] + row[1] * b[3 + c] + row[2] * b[6 + c];
        }
    }
}

/* Copies the 3x3 block into the 6x6 row-major matrix at (row, col), scaled. */
static void put_block(double *jacobian, int row, int col, const double block[9], double scale) {
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
            jacobian[(row + r) * 6 + col + c] = scale * block[r * 3 + c];
        }
    }
}

static void zero_block(double *jacobian, int row, int col) {
    static const double zero[9] = {0.0};
    put_block(jacobian, row, col, zero, 1.0);
}

/* 0.5 (w I + sign [v]x) for the quaternion (v, w). */
static void half_quat_operator(const double q[4], double sign, double out[9]) {
    skew(q, out);
    for (int k = 0; k < 9; ++k) {
        out[k] *= 0.5 * sign;
    }
    out[0] = out[4] = out[8] = 0.5 * q[3];
}

/* The Jacobians' zero blocks are relied on by linalg/assemble.c: keep the two in step. */

/* d e / d (rho_j, phi_j): [R_E 0; 0 0.5 (w I + [v]x)]. */
static void se3_jacobian_j(const double q_error[4], double jacobian[36]) {
    double rotation[9], dq[9];
    pgem_quat_to_matrix(q_error, rotation);
    half_quat_operator(q_error, 1.0, dq);
    put_block(jacobian, 0, 0, rotation, 1.0);
    zero_block(jacobian, 0, 3);
    zero_block(jacobian, 3, 0);
    put_block(jacobian, 3, 3, dq, 1.0);
}

/* d e / d (rho_i, phi_i): [-Rz^T, [t_E]x Rz^T + Rz^T [tz]x; 0, -0.5 (w I - [v]x) Rz^T]. */
static void se3_jacobian_i(const double z[7], const double t_error[3], const double q_error[4],
                           double jacobian[36]) {
    double rz[9], rz_t[9], skew_e[9], skew_z[9], left[9], right[9], dq[9], dq_rz_t[9];
    pgem_quat_to_matrix(z + 3, rz);
    for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c) {
            rz_t[r * 3 + c] = rz[c * 3 + r];
        }
    }
    skew(t_error, skew_e);
    skew(z, skew_z);
    matmul3(skew_e, rz_t, left);
    matmul3(rz_t, skew_z, right);
    for (int k = 0; k < 9; ++k) {
        left[k] += right[k];
    }
    half_quat_operator(q_error, -1.0, dq);
    matmul3(dq, rz_t, dq_rz_t);
    put_block(jacobian, 0, 0, rz_t, -1.0);
    put_block(jacobian, 0, 3, left, 1.0);
    zero_block(jacobian, 3, 0);
    put_block(jacobian, 3, 3, dq_rz_t, -1.0);
}

void pgem_se3_error(const double xi[7], const double xj[7], const double z[7], double e[6],
                    double jacobian_i[36], double jacobian_j[36]) {
    double relative[7], error_pose[7]; /* e is written last, so it may alias an input */
    pgem_se3_between(xi, xj, relative);
    pgem_se3_between(z, relative, error_pose);
    if (error_pose[6] < 0.0) {
        for (int k = 3; k < 7; ++k) {
            error_pose[k] = -error_pose[k];
        }
    }
    if (jacobian_i) {
        se3_jacobian_i(z, error_pose, error_pose + 3, jacobian_i);
    }
    if (jacobian_j) {
        se3_jacobian_j(error_pose + 3, jacobian_j);
    }
    for (int k = 0; k < 6; ++k) {
        e[k] = error_pose[k];
    }
}
