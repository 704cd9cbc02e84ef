// Cross-checks the C geometry layer against an independent Eigen implementation of g2o's errors.
#include <cmath>
#include <cstdint>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <unsupported/Eigen/MatrixFunctions>

// cmocka (through test_util.h) comes last: its fail() macro would clash with std::ios::fail in
// the C++ headers.
#include "test_util.h"

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kSamples = 5000;

// Random samples from test_util.h's splitmix64 generator.
class Rng {
  public:
    explicit Rng(std::uint64_t seed) : state_{seed} {}
    double uniform(double lo, double hi) { return test_uniform_in(&state_, lo, hi); }
    Eigen::Vector3d unit_vector() {
        const double z = uniform(-1.0, 1.0), azimuth = uniform(-kPi, kPi);
        const double r = std::sqrt(1.0 - z * z);
        return {r * std::cos(azimuth), r * std::sin(azimuth), z};
    }
    Eigen::Quaterniond rotation() {
        return Eigen::Quaterniond(Eigen::AngleAxisd(uniform(0.0, kPi), unit_vector()));
    }

  private:
    test_rng_t state_;
};

// ---- conversions between pgem arrays and Eigen types ----------------------------------------

struct Pose2 {
    double v[3];
};
struct Pose3 {
    double v[7];
};

Pose2 random_pose2(Rng &rng) {
    return {{rng.uniform(-10.0, 10.0), rng.uniform(-10.0, 10.0), rng.uniform(-kPi, kPi)}};
}

Pose3 random_pose3(Rng &rng) {
    const Eigen::Quaterniond q = rng.rotation();
    return {{rng.uniform(-10.0, 10.0), rng.uniform(-10.0, 10.0), rng.uniform(-10.0, 10.0), q.x(),
             q.y(), q.z(), q.w()}};
}

Eigen::Isometry2d to_isometry(const double p[3]) {
    Eigen::Isometry2d t = Eigen::Isometry2d::Identity();
    t.linear() = Eigen::Rotation2Dd(p[2]).toRotationMatrix();
    t.translation() = Eigen::Vector2d(p[0], p[1]);
    return t;
}

Eigen::Quaterniond to_quaternion(const double q[4]) {
    return Eigen::Quaterniond(q[3], q[0], q[1], q[2]);
}

Eigen::Isometry3d to_isometry3(const double p[7]) {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.linear() = to_quaternion(p + 3).normalized().toRotationMatrix();
    t.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
    return t;
}

double wrap(double angle) {
    return std::atan2(std::sin(angle), std::cos(angle));
}

void expect_se2_matches(const double p[3], const Eigen::Isometry2d &t, double tolerance,
                        const char *what) {
    assert_near_labelled(p[0], t.translation().x(), tolerance, what);
    assert_near_labelled(p[1], t.translation().y(), tolerance, what);
    const double angle = std::atan2(t.linear()(1, 0), t.linear()(0, 0));
    assert_near_labelled(wrap(p[2] - angle), 0.0, tolerance, what);
}

void expect_se3_matches(const double p[7], const Eigen::Isometry3d &t, double tolerance,
                        const char *what) {
    for (int k = 0; k < 3; ++k) {
        assert_near_labelled(p[k], t.translation()(k), tolerance, what);
    }
    const Eigen::Matrix3d rotation = to_quaternion(p + 3).toRotationMatrix();
    assert_near_labelled((rotation - t.linear()).cwiseAbs().maxCoeff(), 0.0, tolerance, what);
}

// ---- the reference g2o errors ------------------------------------------------------------

Eigen::Vector3d reference_se2_error(const double xi[3], const double xj[3], const double z[3]) {
    const Eigen::Isometry2d e =
        to_isometry(z).inverse() * to_isometry(xi).inverse() * to_isometry(xj);
    return {e.translation().x(), e.translation().y(),
            std::atan2(e.linear()(1, 0), e.linear()(0, 0))};
}

// Returns the error and the w of the error quaternion before the sign flip.
Eigen::Matrix<double, 6, 1> reference_se3_error(const double xi[7], const double xj[7],
                                                const double z[7], double *w_before_flip) {
    const Eigen::Isometry3d e =
        to_isometry3(z).inverse() * to_isometry3(xi).inverse() * to_isometry3(xj);
    Eigen::Quaterniond q(e.rotation());
    q.normalize();
    *w_before_flip = q.w();
    if (q.w() < 0.0) {
        q.coeffs() *= -1.0;
    }
    Eigen::Matrix<double, 6, 1> out;
    out << e.translation(), q.vec();
    return out;
}

// ---- tests -------------------------------------------------------------------------------

void test_se2_error_matches_eigen(void **) {
    Rng rng(1001);
    int checked = 0;
    for (int n = 0; n < kSamples; ++n) {
        const Pose2 xi = random_pose2(rng), xj = random_pose2(rng), z = random_pose2(rng);
        double e[3];
        pgem_se2_error(xi.v, xj.v, z.v, e, nullptr, nullptr);
        const Eigen::Vector3d reference = reference_se2_error(xi.v, xj.v, z.v);
        assert_near_labelled(e[0], reference(0), 1e-11, "se2 error x");
        assert_near_labelled(e[1], reference(1), 1e-11, "se2 error y");
        assert_near_labelled(wrap(e[2] - reference(2)), 0.0, 1e-12, "se2 error angle");
        assert_true(e[2] > -kPi && e[2] <= kPi);
        ++checked;
    }
    assert_int_equal(checked, kSamples);
}

void test_se3_error_matches_eigen(void **) {
    Rng rng(1002);
    int checked = 0;
    for (int n = 0; n < kSamples; ++n) {
        const Pose3 xi = random_pose3(rng), xj = random_pose3(rng), z = random_pose3(rng);
        double e[6], w = 0.0;
        pgem_se3_error(xi.v, xj.v, z.v, e, nullptr, nullptr);
        const Eigen::Matrix<double, 6, 1> reference = reference_se3_error(xi.v, xj.v, z.v, &w);
        if (std::fabs(w) < 1e-6) {
            continue; // the sign of w is not well determined this close to zero
        }
        for (int k = 0; k < 6; ++k) {
            assert_near_labelled(e[k], reference(k), 1e-11, "se3 error");
        }
        ++checked;
    }
    assert_true(checked > kSamples - 10);
}

void test_se2_group_matches_eigen(void **) {
    Rng rng(1003);
    for (int n = 0; n < kSamples; ++n) {
        const Pose2 a = random_pose2(rng), b = random_pose2(rng);
        const Eigen::Isometry2d ta = to_isometry(a.v), tb = to_isometry(b.v);
        double out[3];
        pgem_se2_compose(a.v, b.v, out);
        expect_se2_matches(out, ta * tb, 1e-12, "se2 compose");
        pgem_se2_inverse(a.v, out);
        expect_se2_matches(out, ta.inverse(), 1e-12, "se2 inverse");
        pgem_se2_between(a.v, b.v, out);
        expect_se2_matches(out, ta.inverse() * tb, 1e-12, "se2 between");
    }
}

void test_se3_group_matches_eigen(void **) {
    Rng rng(1004);
    for (int n = 0; n < kSamples; ++n) {
        const Pose3 a = random_pose3(rng), b = random_pose3(rng);
        const Eigen::Isometry3d ta = to_isometry3(a.v), tb = to_isometry3(b.v);
        double out[7];
        pgem_se3_compose(a.v, b.v, out);
        expect_se3_matches(out, ta * tb, 1e-12, "se3 compose");
        pgem_se3_inverse(a.v, out);
        expect_se3_matches(out, ta.inverse(), 1e-12, "se3 inverse");
        pgem_se3_between(a.v, b.v, out);
        expect_se3_matches(out, ta.inverse() * tb, 1e-12, "se3 between");
    }
}

void test_quaternions_match_eigen(void **) {
    Rng rng(1005);
    for (int n = 0; n < kSamples; ++n) {
        const Eigen::Quaterniond qa = rng.rotation(), qb = rng.rotation();
        const double a[4] = {qa.x(), qa.y(), qa.z(), qa.w()};
        const double b[4] = {qb.x(), qb.y(), qb.z(), qb.w()};
        const Eigen::Vector3d v = rng.unit_vector() * rng.uniform(0.0, 10.0);
        double product[4], rotated[3], matrix[9];
        pgem_quat_multiply(a, b, product);
        const Eigen::Quaterniond expected = qa * qb;
        assert_near_labelled((to_quaternion(product).coeffs() - expected.coeffs()).norm(), 0.0,
                             1e-15, "quat multiply");
        pgem_quat_rotate(a, v.data(), rotated);
        assert_near_labelled((Eigen::Vector3d(rotated[0], rotated[1], rotated[2]) - qa * v).norm(),
                             0.0, 1e-14, "quat rotate");
        pgem_quat_to_matrix(a, matrix);
        const Eigen::Matrix3d reference = qa.toRotationMatrix();
        for (int r = 0; r < 3; ++r) {
            for (int c = 0; c < 3; ++c) {
                assert_near_labelled(matrix[r * 3 + c], reference(r, c), 1e-15, "quat to matrix");
            }
        }
    }
}

void test_so3_matches_angle_axis(void **) {
    Rng rng(1006);
    for (int n = 0; n < kSamples; ++n) {
        // Angles up to 2 pi: the exponential need not return w >= 0.
        const double angle = n < 20 ? std::pow(10.0, -n) : rng.uniform(0.0, 2.0 * kPi);
        const Eigen::Vector3d axis = rng.unit_vector();
        const Eigen::Vector3d phi = angle * axis;
        double q[4], back[3];
        pgem_so3_exp(phi.data(), q);
        const Eigen::Quaterniond expected(Eigen::AngleAxisd(angle, axis));
        assert_near_labelled((to_quaternion(q).coeffs() - expected.coeffs()).norm(), 0.0, 1e-15,
                             "so3 exp vs AngleAxisd");
        pgem_so3_log(q, back);
        const Eigen::AngleAxisd recovered(expected);
        const Eigen::Vector3d reference = recovered.angle() * recovered.axis();
        assert_near_labelled((Eigen::Vector3d(back[0], back[1], back[2]) - reference).norm(), 0.0,
                             1e-13, "so3 log vs AngleAxisd");
    }
}

// exp is checked against the matrix exponential of the twist.
void test_exp_matches_matrix_exponential(void **) {
    Rng rng(1007);
    for (int n = 0; n < 1000; ++n) {
        const double angle = n < 10 ? std::pow(10.0, -n - 3) : rng.uniform(0.0, kPi);
        const Eigen::Vector3d phi = angle * rng.unit_vector();
        const Eigen::Vector3d rho(rng.uniform(-5.0, 5.0), rng.uniform(-5.0, 5.0),
                                  rng.uniform(-5.0, 5.0));
        Eigen::Matrix4d twist = Eigen::Matrix4d::Zero();
        twist.block<3, 3>(0, 0) << 0.0, -phi.z(), phi.y(), phi.z(), 0.0, -phi.x(), -phi.y(),
            phi.x(), 0.0;
        twist.block<3, 1>(0, 3) = rho;
        const Eigen::Matrix4d expected = twist.exp();
        const double tangent[6] = {rho.x(), rho.y(), rho.z(), phi.x(), phi.y(), phi.z()};
        double pose[7];
        pgem_se3_exp(tangent, pose);
        Eigen::Isometry3d reference(expected);
        expect_se3_matches(pose, reference, 1e-12, "se3 exp vs matrix exponential");

        const double tangent2[3] = {rho.x(), rho.y(), phi.z()};
        Eigen::Matrix3d twist2 = Eigen::Matrix3d::Zero();
        twist2 << 0.0, -phi.z(), rho.x(), phi.z(), 0.0, rho.y(), 0.0, 0.0, 0.0;
        const Eigen::Matrix3d expected2 = twist2.exp();
        double pose2[3];
        pgem_se2_exp(tangent2, pose2);
        Eigen::Isometry2d reference2(expected2);
        expect_se2_matches(pose2, reference2, 1e-12, "se2 exp vs matrix exponential");
    }
}

} // namespace

int main() {
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_se2_error_matches_eigen),
        cmocka_unit_test(test_se3_error_matches_eigen),
        cmocka_unit_test(test_se2_group_matches_eigen),
        cmocka_unit_test(test_se3_group_matches_eigen),
        cmocka_unit_test(test_quaternions_match_eigen),
        cmocka_unit_test(test_so3_matches_angle_axis),
        cmocka_unit_test(test_exp_matches_matrix_exponential),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
