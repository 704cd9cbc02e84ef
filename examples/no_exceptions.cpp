// The C++ wrapper without exceptions, for firmware: built with -fno-exceptions -fno-rtti and
// linked with pgem::core only. The instance lives in a static std::array (the Graph owns
// nothing), every call returns a pgem_cpp::Status or pgem_cpp::Result, and the throwing
// members (add_pose, optimize, ...) are not even declared in this mode.
#include <array>
#include <cstdio>

#include <pgem/pgem.hpp>

namespace {

std::array<unsigned char, 48 * 1024> block; // all the memory pgem will ever use

bool check(const pgem_cpp::Status &status)
{
    if (!status.ok()) {
        std::printf("%s: %s\n", status.name(), status.message()); // message: no allocation
    }
    return status.ok();
}

} // namespace

int main()
{
    // 2D, 8 poses, 16 edges, 512 factor nonzeros, in `block`
    pgem_cpp::Result<pgem_cpp::Graph2d> made =
        pgem_cpp::Graph2d::init(pgem_cpp::Config{8, 16, 512}, block);
    if (!check(made.status())) {
        return 1;
    }
    pgem_cpp::Graph2d graph = std::move(*made);
    // A triangle walked with a drifting guess and closed by one loop.
    const Eigen::Isometry2d turn(Eigen::Translation2d(1.0, 0.0) *
                                 Eigen::Rotation2Dd(2.0 * static_cast<double>(EIGEN_PI) / 3));
    const Eigen::Matrix3d information = Eigen::Vector3d(50, 50, 200).asDiagonal();
    Eigen::Isometry2d guess = Eigen::Isometry2d::Identity();
    bool ok = check(graph.try_add_pose(0, guess));
    for (pgem_cpp::Id id = 1; ok && id <= 3; id++) {
        guess = guess * turn * Eigen::Rotation2Dd(0.05);
        ok = check(graph.try_add_pose(id, guess)) &&
             check(graph.try_add_edge(id - 1, id, turn, information).status());
    }
    const Eigen::Isometry2d home = Eigen::Isometry2d::Identity(); // pose 3 is where pose 0 was
    ok = ok && check(graph.try_add_edge(3, 0, home, information, PGEM_EDGE_LOOP).status());
    if (!ok) {
        return 1;
    }
    // A failure is a value, not an exception: an edge to a pose that does not exist.
    const pgem_cpp::Result<std::uint32_t> refused =
        graph.try_add_edge(3, 42, turn, information, PGEM_EDGE_LOOP);
    std::printf("expected failure: %s (%s)\n", refused.status().name(), refused.message());

    const pgem_cpp::Result<pgem_cpp::Summary> solved = graph.try_optimize();
    if (!check(solved.status())) {
        return 1;
    }
    const pgem_cpp::Result<Eigen::Isometry2d> corner = graph.try_pose(2);
    std::printf("chi2 %.3f -> %.6f (%s); pose 2: x %.3f  y %.3f\n", solved->initial_chi2,
                solved->final_chi2, solved->termination_name(), corner->translation().x(),
                corner->translation().y());
    return corner.ok() && solved->final_chi2 < 1e-9 ? 0 : 1;
}
