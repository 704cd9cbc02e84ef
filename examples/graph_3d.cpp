// A 3D pose graph in C++ with Eigen: a robot climbs a spiral ramp (three turns of twelve poses),
// its odometry has a heading bias, and each pose sees the one a turn below. pgem_cpp::Graph3d
// takes Eigen::Isometry3d poses and 6x6 information matrices, and throws pgem_cpp::Error.
#include <cmath>
#include <cstdio>

#include <pgem/pgem.hpp>

namespace {

constexpr int kPerTurn = 12, kPoses = 3 * kPerTurn + 1;

// Ground truth: radius 5 m, 0.5 m up per turn, facing along the ramp.
Eigen::Isometry3d truth(int k)
{
    const double angle = 2.0 * static_cast<double>(EIGEN_PI) * k / kPerTurn;
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() << 5.0 * std::cos(angle), 5.0 * std::sin(angle), 0.5 * k / kPerTurn;
    const double quarter_turn = static_cast<double>(EIGEN_PI) / 2;
    pose.linear() = Eigen::AngleAxisd(angle + quarter_turn, Eigen::Vector3d::UnitZ()).matrix();
    return pose;
}

} // namespace

int main()
{
    // Information for sigma 5 cm (translation) and 0.01 rad (rotation, angle-axis), converted
    // to pgem's convention: its 3D rotation error is the quaternion's vector part, about half
    // the angle, so the rotation block becomes 4x (information_from_angle_axis does that).
    Eigen::Matrix<double, 6, 6> angle_axis = Eigen::Matrix<double, 6, 6>::Zero();
    angle_axis.diagonal() << 400, 400, 400, 1e4, 1e4, 1e4;
    const pgem_cpp::Graph3d::Information information =
        pgem_cpp::information_from_angle_axis(angle_axis);

    try {
        pgem_cpp::Graph3d graph(pgem_cpp::Config{kPoses, 2 * kPoses});
        // A biased gyro: every step turns 2 degrees too far and climbs 1 cm too much.
        Eigen::Isometry3d bias = Eigen::Isometry3d::Identity();
        bias.linear() = Eigen::AngleAxisd(0.035, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        bias.translation().z() = 0.01;
        Eigen::Isometry3d guess = truth(0);
        graph.add_pose(0, guess);
        for (int k = 1; k < kPoses; k++) {
            const Eigen::Isometry3d step = truth(k - 1).inverse() * truth(k);
            guess = guess * step * bias; // the initial guess drifts ...
            graph.add_pose(k, guess);
            graph.add_edge(k - 1, k, step, information); // ... the measurements do not
        }
        for (int k = kPerTurn; k < kPoses; k += 2) { // every other pose sees a turn below
            graph.add_edge(k - kPerTurn, k, truth(k - kPerTurn).inverse() * truth(k), information,
                           PGEM_EDGE_LOOP);
        }

        const pgem_cpp::Summary summary = graph.optimize();
        double worst = 0.0;
        for (const auto &entry : graph.poses()) { // id, pose, fixed flag
            const Eigen::Vector3d error =
                entry.pose.translation() - truth(static_cast<int>(entry.id)).translation();
            worst = std::fmax(worst, error.norm());
        }
        const int shown = kPoses - 3;
        const Eigen::Isometry3d pose = graph.pose(shown);
        const double yaw = std::atan2(pose.linear()(1, 0), pose.linear()(0, 0));
        std::printf("%u poses, %u edges: chi2 %.3f -> %.6f after %u iterations (%s)\n",
                    graph.pose_count(), graph.edge_count(), summary.initial_chi2,
                    summary.final_chi2, summary.iterations, summary.termination_name());
        std::printf("pose %d: x %.3f  y %.3f  z %.3f  yaw %.3f\n", shown, pose.translation().x(),
                    pose.translation().y(), pose.translation().z(), yaw);
        std::printf("largest position error against the truth: %.6f m\n", worst);
        return worst < 1e-6 ? 0 : 1;
    } catch (const pgem_cpp::Error &error) {
        std::fprintf(stderr, "%s\n", error.what());
        return 1;
    }
}
