/** @file
 * pgem geometry: SE(2) and SE(3) operations with analytic Jacobians. Knows nothing of graphs. */
#ifndef PGEM_GEOMETRY_H
#define PGEM_GEOMETRY_H

#ifdef __cplusplus
extern "C" {
#endif

/*
 * Representations (all arrays of double):
 *   SE(2) pose      [x, y, theta]                 theta in (-pi, pi]
 *   SE(2) tangent   [dx, dy, dtheta]
 *   SE(3) pose      [x, y, z, qx, qy, qz, qw]     unit quaternion, w last (g2o order)
 *   SE(3) tangent   [rho_x, rho_y, rho_z, phi_x, phi_y, phi_z]
 *   Jacobians       row-major, J[r * n + c] = d out_r / d in_c
 *
 * Error conventions are g2o's, so chi2 values compare with g2o and GTSAM on the same files:
 *   SE(2): e = (dx, dy, dtheta) of Z^-1 Xi^-1 Xj, angle wrapped to (-pi, pi].
 *   SE(3): e = (translation, vector part of the unit quaternion with w >= 0) of Z^-1 Xi^-1 Xj.
 *          The rotation part is about half the rotation angle: an information value for an
 *          angle-axis error is 4x smaller than the value pgem (and g2o) expect.
 *
 * Perturbations the Jacobians refer to (what the solver steps in):
 *   SE(2): additive, X [+] d = (x + dx, y + dy, wrap(theta + dtheta)).
 *   SE(3): right, decoupled, X [+] d = (t + R rho, R Exp(phi)).
 */

/** Wraps an angle to (-pi, pi]. */
double pgem_wrap_angle(double angle);

/** out = a * b. out may alias a or b. */
void pgem_se2_compose(const double a[3], const double b[3], double out[3]);
/** out = a^-1. out may alias a. */
void pgem_se2_inverse(const double a[3], double out[3]);
/** out = a^-1 * b. out may alias a or b. */
void pgem_se2_between(const double a[3], const double b[3], double out[3]);
/** Group exponential (true SE(2) exp, with the V matrix) and its inverse. */
void pgem_se2_exp(const double tangent[3], double out[3]);
void pgem_se2_log(const double pose[3], double tangent[3]);
/** out = x [+] delta (additive perturbation, see above). out may alias x. */
void pgem_se2_boxplus(const double x[3], const double delta[3], double out[3]);
/** Edge error e = t2v(Z^-1 Xi^-1 Xj); Jacobians (3x3) wrt the perturbation of xi and xj;
 * either Jacobian pointer may be NULL. */
void pgem_se2_error(const double xi[3], const double xj[3], const double z[3], double e[3],
                    double jacobian_i[9], double jacobian_j[9]);

/* Quaternion helpers, [qx, qy, qz, qw]. */
/** Returns the norm before normalising in place. */
double pgem_quat_normalize(double q[4]);
/** out = a * b (Hamilton product). out may alias a or b. */
void pgem_quat_multiply(const double a[4], const double b[4], double out[4]);
/** Rotates v by unit quaternion q: out = R(q) v. out may alias v. */
void pgem_quat_rotate(const double q[4], const double v[3], double out[3]);
/** Row-major 3x3 rotation matrix of a unit quaternion. */
void pgem_quat_to_matrix(const double q[4], double rotation[9]);
/** SO(3) exponential of an angle-axis vector and its inverse (angle in [0, pi]). */
void pgem_so3_exp(const double phi[3], double q[4]);
void pgem_so3_log(const double q[4], double phi[3]);

/** out = a * b. out may alias a or b. */
void pgem_se3_compose(const double a[7], const double b[7], double out[7]);
/** out = a^-1. out may alias a. */
void pgem_se3_inverse(const double a[7], double out[7]);
/** out = a^-1 * b. out may alias a or b. */
void pgem_se3_between(const double a[7], const double b[7], double out[7]);
/** Group exponential (with the V matrix) and its inverse. */
void pgem_se3_exp(const double tangent[6], double out[7]);
void pgem_se3_log(const double pose[7], double tangent[6]);
/** out = x [+] delta (right, decoupled perturbation, see above). out may alias x. */
void pgem_se3_boxplus(const double x[7], const double delta[6], double out[7]);
/** Edge error e = (t, qvec) of Z^-1 Xi^-1 Xj with w >= 0; Jacobians (6x6) wrt the perturbation
 * of xi and xj; either Jacobian pointer may be NULL. */
void pgem_se3_error(const double xi[7], const double xj[7], const double z[7], double e[6],
                    double jacobian_i[36], double jacobian_j[36]);

#ifdef __cplusplus
}
#endif

#endif /* PGEM_GEOMETRY_H */
