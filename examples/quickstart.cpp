// Quick start in C++: the square walk of quickstart.c through pgem/pgem.hpp, with Eigen types.
#include <cstdio>

#include <pgem/pgem.hpp>

int main()
{
    try {
        pgem_cpp::Graph2d graph(pgem_cpp::Config{16, 32}); // 2D, 16 poses, 32 edges: one block
        using Pose = pgem_cpp::Graph2d::Pose;              // Eigen::Isometry2d
        const Pose odometry(Eigen::Translation2d(1, 0) * Eigen::Rotation2Dd(EIGEN_PI / 2));
        const Pose drifting(Eigen::Translation2d(1.05, 0.02) * Eigen::Rotation2Dd(1.62));
        const Eigen::Matrix3d information = Eigen::Vector3d(100, 100, 400).asDiagonal();
        Pose guess = Pose::Identity();
        graph.add_pose(0, guess);
        for (pgem_cpp::Id id = 1; id <= 4; id++) {
            guess = guess * drifting; // initial guess: drifting dead reckoning
            graph.add_pose(id, guess);
            graph.add_edge(id - 1, id, odometry, information);
        }
        graph.add_edge(4, 0, Pose::Identity(), information, PGEM_EDGE_LOOP); // back home
        const pgem_cpp::Summary summary = graph.optimize();
        std::printf("chi2 %.3f -> %.6f (%s)\n", summary.initial_chi2, summary.final_chi2,
                    summary.termination_name());
        for (const auto &entry : graph.poses()) { // id, pose (Eigen), fixed flag
            std::printf("pose %u: x %6.3f  y %6.3f\n", static_cast<unsigned>(entry.id),
                        entry.pose.translation().x(), entry.pose.translation().y());
        }
        return summary.final_chi2 < 1e-9 ? 0 : 1;
    } catch (const pgem_cpp::Error &error) { // code name and message: "PGEM_ERR_...: ..."
        std::fprintf(stderr, "%s\n", error.what());
        return 1;
    }
}
