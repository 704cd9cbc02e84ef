// Links against an installed pgem through the C++ wrapper and solves a three-pose triangle.
#include <cstdio>

#include <pgem/pgem.hpp>

int main()
{
    using Pose = pgem_cpp::Graph2d::Pose;
    pgem_cpp::Graph2d graph(pgem_cpp::Config{3, 3});
    const Eigen::Matrix3d information = Eigen::Matrix3d::Identity();
    const Pose step(Eigen::Translation2d(1, 0) * Eigen::Rotation2Dd(2.0 * EIGEN_PI / 3));
    graph.add_pose(0, Pose::Identity());
    graph.add_pose(1, Pose(Eigen::Translation2d(1.1, 0.1) * Eigen::Rotation2Dd(2.2)));
    graph.add_pose(2, Pose(Eigen::Translation2d(0.4, 0.9) * Eigen::Rotation2Dd(4.0)));
    graph.add_edge(0, 1, step, information);
    graph.add_edge(1, 2, step, information);
    graph.add_edge(2, 0, step, information, PGEM_EDGE_LOOP);
    const pgem_cpp::Summary summary = graph.optimize();
    std::printf("consumer_cpp: chi2 %.3g -> %.3g\n", summary.initial_chi2, summary.final_chi2);
    return summary.final_chi2 < summary.initial_chi2 ? 0 : 1;
}
