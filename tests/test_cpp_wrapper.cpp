// The C++ wrapper (pgem/pgem.hpp): Eigen conversions, ownership and moves, both error paths,
// edge and pose iteration, robust solves, callbacks, file loading, and an allocation count that
// proves a solve through the wrapper makes no allocation (malloc family and operator new).
#include <pgem/pgem.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <new>
#include <string>
#include <type_traits>
#include <utility>

#include "test_alloc_counters.h"

// cmocka (through test_util.h) comes last: its fail() macro would clash with the C++ headers.
#include "test_util.h"

// ---- allocation counters ------------------------------------------------------------------------
// test_alloc_counters.h interposes and counts the malloc family (as tests/test_alloc.c does); the
// global operator new and delete are replaced here, so both C and C++ allocations are seen.
// AddressSanitizer owns malloc, so the sanitizer build does not count (the plain build does).
namespace {
long news = 0; // operator new calls of any form
} // namespace

#if !TEST_UNDER_SANITIZER
namespace {
void *counted_new(std::size_t size)
{
    news++;
    void *pointer = std::malloc(size != 0 ? size : 1);
    if (pointer == nullptr) {
        throw std::bad_alloc();
    }
    return pointer;
}

void *counted_aligned_new(std::size_t size, std::align_val_t alignment)
{
    news++;
    const std::size_t align = static_cast<std::size_t>(alignment);
    void *pointer = std::aligned_alloc(align, (size + align - 1) / align * align);
    if (pointer == nullptr) {
        throw std::bad_alloc();
    }
    return pointer;
}
} // namespace

void *operator new(std::size_t size) { return counted_new(size); }
void *operator new[](std::size_t size) { return counted_new(size); }
void *operator new(std::size_t size, std::align_val_t alignment)
{
    return counted_aligned_new(size, alignment);
}
void *operator new[](std::size_t size, std::align_val_t alignment)
{
    return counted_aligned_new(size, alignment);
}
void operator delete(void *pointer) noexcept { std::free(pointer); }
void operator delete[](void *pointer) noexcept { std::free(pointer); }
void operator delete(void *pointer, std::size_t) noexcept { std::free(pointer); }
void operator delete[](void *pointer, std::size_t) noexcept { std::free(pointer); }
void operator delete(void *pointer, std::align_val_t) noexcept { std::free(pointer); }
void operator delete[](void *pointer, std::align_val_t) noexcept { std::free(pointer); }
void operator delete(void *pointer, std::size_t, std::align_val_t) noexcept { std::free(pointer); }
void operator delete[](void *pointer, std::size_t, std::align_val_t) noexcept
{
    std::free(pointer);
}
#endif

namespace {

// ---- helpers ------------------------------------------------------------------------------------

constexpr double kPi = 3.14159265358979323846;

Eigen::Isometry2d se2(double x, double y, double theta)
{
    return Eigen::Translation2d(x, y) * Eigen::Rotation2Dd(theta);
}

Eigen::Isometry3d se3(const Eigen::Vector3d &translation, const Eigen::Vector3d &axis, double angle)
{
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.translation() = translation;
    pose.linear() = Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
    return pose;
}

Eigen::Matrix3d diagonal3(double xy, double theta)
{
    return Eigen::Vector3d(xy, xy, theta).asDiagonal();
}

// Deterministic noise in [-1, 1].
double wobble(int k, int channel)
{
    return std::sin(12.9898 * k + 78.233 * channel) * 0.5 + std::sin(3.7 * k * (channel + 1)) * 0.5;
}

// A 2D ring of n poses (radius 10), noisy odometry, a true loop closure every `stride` poses and
// `false_loops` wrong ones; returns the indices of the wrong ones (at most 8) in `wrong`.
template <class Graph>
void build_ring(Graph &graph, int n, int stride, int false_loops, std::uint32_t *wrong)
{
    const Eigen::Matrix3d information = diagonal3(2500.0, 10000.0); // sigma 2 cm, 0.01 rad
    auto truth = [n](int k) {
        const double angle = 2.0 * kPi * k / n;
        return se2(10.0 * std::cos(angle), 10.0 * std::sin(angle), angle + kPi / 2.0);
    };
    Eigen::Isometry2d estimate = truth(0);
    graph.add_pose(0, estimate);
    for (int k = 1; k < n; k++) {
        const Eigen::Isometry2d step = truth(k - 1).inverse() * truth(k);
        const Eigen::Isometry2d noisy =
            step * se2(0.01 * wobble(k, 0), 0.01 * wobble(k, 1), 0.005 * wobble(k, 2));
        estimate = estimate * noisy;
        graph.add_pose(static_cast<pgem_cpp::Id>(k), estimate);
        graph.add_edge(static_cast<pgem_cpp::Id>(k - 1), static_cast<pgem_cpp::Id>(k), noisy,
                       information);
    }
    for (int k = stride; k < n; k += stride) {
        graph.add_edge(static_cast<pgem_cpp::Id>(k), static_cast<pgem_cpp::Id>(k - stride),
                       truth(k).inverse() * truth(k - stride), information, PGEM_EDGE_LOOP);
    }
    for (int f = 0; f < false_loops; f++) {
        const int from = 3 + 7 * f, to = from + n / 2;
        wrong[f] = graph.add_edge(static_cast<pgem_cpp::Id>(from), static_cast<pgem_cpp::Id>(to),
                                  se2(1.0, -0.5, 0.3), information, PGEM_EDGE_LOOP);
    }
}

// ---- types and conversions ----------------------------------------------------------------------

static_assert(!std::is_copy_constructible<pgem_cpp::Graph2d>::value, "a Graph is not copyable");
static_assert(!std::is_copy_assignable<pgem_cpp::Graph3d>::value, "a Graph is not copyable");
static_assert(std::is_nothrow_move_constructible<pgem_cpp::Graph2d>::value, "moves do not throw");
static_assert(std::is_nothrow_move_assignable<pgem_cpp::Graph3d>::value, "moves do not throw");
static_assert(std::is_same<pgem_cpp::Graph2d::Pose, Eigen::Isometry2d>::value, "2D poses");
static_assert(std::is_same<pgem_cpp::Graph3d::Pose, Eigen::Isometry3d>::value, "3D poses");
static_assert(std::is_same<pgem_cpp::Graph2d::Information, Eigen::Matrix3d>::value,
              "2D information");
static_assert(std::is_same<pgem_cpp::Graph3d::Information, Eigen::Matrix<double, 6, 6>>::value,
              "3D information");
static_assert(pgem_cpp::Graph3d::tangent_size == 6 && pgem_cpp::Graph2d::dimension == 2, "sizes");

void test_counters_work(void **)
{
    if (TEST_UNDER_SANITIZER) {
        skip();
    }
    const long before = allocations, news_before = news;
    void *volatile pointer = std::malloc(32);
    int *volatile value = new int(3);
    const long after = allocations, news_after = news;
    delete value;
    std::free(pointer);
    assert_int_equal(after - before, 2); // malloc, and the malloc under operator new
    assert_int_equal(news_after - news_before, 1);
}

void test_buffer_graph_2d(void **)
{
    // The quick start's square walk, in a caller-owned std::array.
    static std::array<unsigned char, 64 * 1024> block;
    const pgem_cpp::Config config{16, 32, 2048};
    assert_true(pgem_cpp::Graph2d::memory_size(config) <= block.size());
    pgem_cpp::Graph2d graph(config, block);
    assert_true(graph.valid());
    assert_false(graph.owns_block());
    assert_int_equal(graph.memory_stats().block_bytes, block.size());
    assert_int_equal(graph.config().dimension, 2);
    assert_int_equal(graph.config().max_edges, 32);

    const Eigen::Isometry2d odometry = se2(1.0, 0.0, kPi / 2.0), drifting = se2(1.05, 0.02, 1.62);
    const Eigen::Matrix3d information = diagonal3(100.0, 400.0);
    Eigen::Isometry2d guess = Eigen::Isometry2d::Identity();
    graph.add_pose(0, guess);
    for (pgem_cpp::Id id = 1; id <= 4; id++) {
        guess = guess * drifting;
        graph.add_pose(id, guess);
        assert_int_equal(graph.add_edge(id - 1, id, odometry, information), id - 1);
    }
    const Eigen::Isometry2d home = Eigen::Isometry2d::Identity();
    assert_int_equal(graph.add_edge(4, 0, home, information, PGEM_EDGE_LOOP), 4);
    assert_near(graph.chi2(), pgem_total_chi2(graph.c_handle()), 0.0);

    const pgem_cpp::Summary summary = graph.optimize();
    assert_true(summary.usable);
    assert_true(summary.converged());
    assert_true(summary.final_chi2 < 1e-9);
    assert_string_equal(summary.termination_name(), pgem_termination_name(summary.termination));
    const Eigen::Isometry2d pose2 = graph.pose(2);
    assert_near(pose2.translation().x(), 1.0, 1e-6);
    assert_near(pose2.translation().y(), 1.0, 1e-6);
    assert_true(pose2.linear().isApprox(Eigen::Rotation2Dd(kPi).toRotationMatrix(), 1e-6));

    // pose iteration: insertion order, values equal to pose(id)
    std::uint32_t count = 0;
    for (const pgem_cpp::PoseEntry<2> &entry : graph.poses()) {
        assert_int_equal(entry.index, count);
        assert_int_equal(entry.id, count);
        assert_false(entry.fixed);
        assert_true(entry.pose.isApprox(graph.pose(entry.id), 1e-15));
        count++;
    }
    assert_int_equal(count, 5);
    graph.fix_pose(3);
    assert_true(graph.pose_at(3).fixed);
    assert_false(graph.pose_at(2).fixed);

    // edge iteration: kinds, measurement and information round trip
    std::uint32_t edges = 0, loops = 0;
    for (const auto &edge : graph.edges()) {
        assert_int_equal(edge.index(), edges);
        assert_true(edge.information().isApprox(information));
        assert_true(edge.weight() == 1.0 && edge.active());
        edges++;
    }
    for (const auto &edge : graph.loops()) {
        assert_true(edge.is_loop());
        assert_int_equal(edge.from(), 4);
        assert_int_equal(edge.to(), 0);
        assert_true(edge.measurement().isApprox(Eigen::Isometry2d::Identity()));
        loops++;
    }
    assert_int_equal(edges, 5);
    assert_int_equal(loops, 1);
    assert_true(graph.edge(1).measurement().isApprox(odometry, 1e-15));
    assert_near(graph.edge_chi2(4), 0.0, 1e-9);
}

void test_conversions_3d(void **)
{
    pgem_cpp::Graph3d graph(pgem_cpp::Config{4, 4});
    assert_true(graph.owns_block());
    const Eigen::Isometry3d a = se3({1.0, 2.0, 3.0}, {1.0, 2.0, 3.0}, 0.7);
    const Eigen::Isometry3d b = se3({-2.0, 0.5, 1.0}, {0.0, -1.0, 0.2}, 2.9);
    graph.add_pose(10, a);
    graph.add_pose(20, b);
    assert_true(graph.pose(10).isApprox(a, 1e-14));
    assert_true(graph.pose(20).isApprox(b, 1e-14));
    // the C layout: [x y z qx qy qz qw]
    double raw[7];
    assert_int_equal(pgem_pose(graph.c_handle(), 10, raw), PGEM_OK);
    const Eigen::Quaterniond q(a.linear());
    assert_near(raw[2], 3.0, 1e-15);
    const double dot = raw[3] * q.x() + raw[4] * q.y() + raw[5] * q.z() + raw[6] * q.w();
    assert_near(std::fabs(dot), 1.0, 1e-14); // the same rotation (q or -q)

    // a full symmetric information matrix: column-major Eigen in, row-major C storage, back out
    Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity() * 50.0;
    information(0, 1) = information(1, 0) = 3.0;
    information(0, 5) = information(5, 0) = -2.0;
    information(2, 4) = information(4, 2) = 1.5;
    const Eigen::Isometry3d z = a.inverse() * b;
    const std::uint32_t index = graph.add_edge(10, 20, z, information, PGEM_EDGE_LOOP);
    const pgem_cpp::Graph3d::Edge edge = graph.edge(index);
    assert_true(edge.information() == information);
    assert_near(edge.c_view().information[5], -2.0, 0.0);      // row 0, column 5
    assert_near(edge.c_view().information[2 * 6 + 4], 1.5, 0.0); // row 2, column 4
    assert_true(edge.measurement().isApprox(z, 1e-14));
    assert_near(graph.edge_chi2(index), 0.0, 1e-20);
    assert_true(edge.state() == PGEM_LOOP_ACCEPTED);

    // a linear part that is not a rotation is refused
    Eigen::Isometry3d scaled = a;
    scaled.linear() *= 1.1;
    const pgem_cpp::Status status = graph.try_add_pose(30, scaled);
    assert_int_equal(status.code(), PGEM_ERR_ROTATION);
    assert_contains(status.message(), "quaternion");
}

void test_information_from_angle_axis(void **)
{
    // An angle-axis information diag(t, r) becomes diag(t, 4 r): the chi2 pgem computes for a
    // small rotation error phi then matches phi^T r phi.
    Eigen::Matrix<double, 6, 6> angle_axis = Eigen::Matrix<double, 6, 6>::Zero();
    angle_axis.diagonal() << 10.0, 20.0, 30.0, 100.0, 200.0, 300.0;
    angle_axis(0, 4) = angle_axis(4, 0) = 5.0;
    const Eigen::Matrix<double, 6, 6> converted = pgem_cpp::information_from_angle_axis(angle_axis);
    assert_near(converted(0, 0), 10.0, 0.0);
    assert_near(converted(3, 3), 400.0, 0.0);
    assert_near(converted(5, 5), 1200.0, 0.0);
    assert_near(converted(0, 4), 10.0, 0.0);
    assert_near(converted(4, 0), 10.0, 0.0);

    pgem_cpp::Graph3d graph(pgem_cpp::Config{2, 1});
    const Eigen::Vector3d phi(0.002, -0.001, 0.003);
    Eigen::Isometry3d rotated = Eigen::Isometry3d::Identity();
    rotated.linear() = Eigen::AngleAxisd(phi.norm(), phi.normalized()).toRotationMatrix();
    graph.add_pose(0, Eigen::Isometry3d::Identity());
    graph.add_pose(1, rotated);
    graph.add_edge(0, 1, Eigen::Isometry3d::Identity(), converted);
    const double expected = phi.transpose() * angle_axis.bottomRightCorner<3, 3>() * phi;
    assert_near(graph.edge_chi2(0) / expected, 1.0, 1e-5);
}

// ---- errors -------------------------------------------------------------------------------------

void test_errors_throw(void **)
{
    pgem_cpp::Graph2d graph(pgem_cpp::Config{2, 2});
    graph.add_pose(4, se2(0, 0, 0));
    try {
        graph.add_pose(4, se2(1, 0, 0));
        fail_msg("no exception for a duplicate id");
    } catch (const pgem_cpp::Error &error) {
        assert_int_equal(error.code(), PGEM_ERR_DUPLICATE_ID);
        assert_string_equal(error.name(), "PGEM_ERR_DUPLICATE_ID");
        assert_string_equal(error.what(), "PGEM_ERR_DUPLICATE_ID: pose id 4 already exists");
    }
    graph.add_pose(5, se2(1, 0, 0));
    try {
        graph.add_pose(6, se2(2, 0, 0));
        fail_msg("no exception past the capacity");
    } catch (const pgem_cpp::Error &error) {
        assert_int_equal(error.code(), PGEM_ERR_CAPACITY);
        assert_contains(error.what(), "max_poses = 2");
    }
    try {
        (void)graph.pose(99);
        fail_msg("no exception for an unknown id");
    } catch (const pgem_cpp::Error &error) {
        assert_int_equal(error.code(), PGEM_ERR_UNKNOWN_ID);
        assert_contains(error.what(), "no pose with id 99");
    }
    try {
        (void)graph.edge(7);
        fail_msg("no exception for an edge index out of range");
    } catch (const pgem_cpp::Error &error) {
        assert_int_equal(error.code(), PGEM_ERR_INVALID_ARGUMENT);
        assert_contains(error.what(), "edge index 7 is out of range (0 edges)");
    }
    Eigen::Matrix3d indefinite = diagonal3(1.0, 1.0);
    indefinite(2, 2) = -1.0;
    try {
        graph.add_edge(4, 5, se2(1, 0, 0), indefinite);
        fail_msg("no exception for an indefinite information matrix");
    } catch (const pgem_cpp::Error &error) {
        assert_int_equal(error.code(), PGEM_ERR_INFORMATION);
        assert_int_equal(graph.edge_count(), 0); // a failed call changes nothing
    }
    try {
        graph.optimize(); // no edge
        fail_msg("no exception for an empty problem");
    } catch (const pgem_cpp::Error &error) {
        assert_int_equal(error.code(), PGEM_ERR_EMPTY);
    }
    // a buffer too small, and an invalid config
    std::array<unsigned char, 64> tiny{};
    try {
        pgem_cpp::Graph2d small(pgem_cpp::Config{16}, tiny);
        fail_msg("no exception for a buffer too small");
    } catch (const pgem_cpp::Error &error) {
        assert_int_equal(error.code(), PGEM_ERR_BUFFER_TOO_SMALL);
    }
    try {
        pgem_cpp::Graph3d huge(pgem_cpp::Config{PGEM_MAX_POSES_LIMIT + 1u});
        fail_msg("no exception for an invalid config");
    } catch (const std::runtime_error &error) { // pgem_cpp::Error is a std::runtime_error
        assert_contains(error.what(), "PGEM_ERR_CONFIG");
    }
    // Result::value() throws, operator* does not check
    pgem_cpp::Result<Eigen::Isometry2d> missing = graph.try_pose(1234);
    assert_false(missing.ok());
    try {
        (void)missing.value();
        fail_msg("value() of an error did not throw");
    } catch (const pgem_cpp::Error &error) {
        assert_int_equal(error.code(), PGEM_ERR_UNKNOWN_ID);
    }
}

void test_errors_status(void **)
{
    pgem_cpp::Graph2d graph(pgem_cpp::Config{4, 4});
    const pgem_cpp::Status ok = graph.try_add_pose(1, se2(0, 0, 0));
    assert_true(ok.ok() && static_cast<bool>(ok));
    assert_int_equal(ok.code(), PGEM_OK);
    assert_string_equal(ok.message(), "");
    assert_true(graph.try_add_pose(2, se2(1, 0, 0)).ok());

    const pgem_cpp::Status duplicate = graph.try_add_pose(1, se2(0, 0, 0));
    assert_false(duplicate.ok());
    assert_int_equal(duplicate.code(), PGEM_ERR_DUPLICATE_ID);
    assert_string_equal(duplicate.name(), "PGEM_ERR_DUPLICATE_ID");
    assert_string_equal(duplicate.message(), "pose id 1 already exists");
    assert_ptr_equal(duplicate.message(), pgem_last_error(graph.c_handle())); // no copy

    const pgem_cpp::Result<std::uint32_t> unknown =
        graph.try_add_edge(1, 9, se2(1, 0, 0), diagonal3(1, 1), PGEM_EDGE_LOOP);
    assert_int_equal(unknown.code(), PGEM_ERR_UNKNOWN_ID);
    assert_contains(unknown.message(), "9");
    const pgem_cpp::Result<std::uint32_t> added =
        graph.try_add_edge(1, 2, se2(1, 0, 0), diagonal3(1, 1));
    assert_true(added.ok());
    assert_int_equal(added.value(), 0);

    // reads cannot record a message in the C API: the Status carries the code's description
    const pgem_cpp::Result<Eigen::Isometry2d> missing = graph.try_pose(77);
    assert_int_equal(missing.code(), PGEM_ERR_UNKNOWN_ID);
    assert_string_equal(missing.message(), pgem_error_description(PGEM_ERR_UNKNOWN_ID));
    assert_int_equal(graph.try_edge(3).code(), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(graph.try_pose_at(9).code(), PGEM_ERR_INVALID_ARGUMENT);
    assert_int_equal(graph.try_edge_chi2(1).code(), PGEM_ERR_INVALID_ARGUMENT);
    assert_true(graph.try_fix_pose(1).ok());
    assert_int_equal(graph.try_fix_pose(8).code(), PGEM_ERR_UNKNOWN_ID);
    assert_int_equal(graph.try_set_pose(8, se2(0, 0, 0)).code(), PGEM_ERR_UNKNOWN_ID);
    assert_int_equal(graph.try_set_pose(2, se2((double)NAN, 0, 0)).code(), PGEM_ERR_NOT_FINITE);

    // construction without exceptions
    std::array<double, 8> tiny{};
    pgem_cpp::Result<pgem_cpp::Graph2d> failed =
        pgem_cpp::Graph2d::init(pgem_cpp::Config{16}, tiny);
    assert_int_equal(failed.code(), PGEM_ERR_BUFFER_TOO_SMALL);
    assert_string_equal(failed.message(), pgem_error_description(PGEM_ERR_BUFFER_TOO_SMALL));
    assert_false(failed->valid());
    pgem_cpp::Result<pgem_cpp::Graph2d> hosted = pgem_cpp::Graph2d::create(pgem_cpp::Config{8});
    assert_true(hosted.ok());
    pgem_cpp::Graph2d taken = std::move(*hosted);
    assert_true(taken.valid() && taken.owns_block());
    assert_false(hosted->valid());

    // the optimize summary is there even when the solve fails
    pgem_cpp::Graph2d lonely(pgem_cpp::Config{2, 1});
    assert_true(lonely.try_add_pose(0, se2(0, 0, 0)).ok());
    const pgem_cpp::Result<pgem_cpp::Summary> empty = lonely.try_optimize();
    assert_int_equal(empty.code(), PGEM_ERR_EMPTY);
    assert_false(empty->usable);
}

// ---- ownership ----------------------------------------------------------------------------------

void test_moves_and_ownership(void **)
{
    const long before = allocations, released = releases;
    {
        pgem_cpp::Graph2d first(pgem_cpp::Config{8});
        assert_int_equal(allocations - before, TEST_UNDER_SANITIZER ? 0 : 1); // one block
        first.add_pose(1, se2(1, 2, 3));
        pgem_cpp::Graph2d second(std::move(first));
        assert_false(first.valid()); // NOLINT: moved from on purpose
        assert_false(first.owns_block());
        assert_true(second.valid() && second.owns_block());
        assert_true(second.pose(1).isApprox(se2(1, 2, 3)));
        // calls on an empty Graph fail cleanly
        const pgem_cpp::Status status = first.try_add_pose(2, se2(0, 0, 0));
        assert_int_equal(status.code(), PGEM_ERR_INVALID_ARGUMENT);
        assert_int_equal(first.pose_count(), 0);
        assert_true(first.edges().begin() == first.edges().end());

        pgem_cpp::Graph2d third(pgem_cpp::Config{4});
        third = std::move(second); // frees third's block, takes second's
        assert_true(third.pose(1).isApprox(se2(1, 2, 3)));
        third = pgem_cpp::Graph2d(); // frees it
        assert_false(third.valid());
    }
    if (!TEST_UNDER_SANITIZER) {
        assert_int_equal(allocations - before, 2);
        assert_int_equal(releases - released, 2);
    }

    // borrowing an instance made in C: the wrapper leaves it alone
    pgem_config_t config{};
    config.dimension = 2;
    config.max_poses = 4;
    pgem_t *instance = nullptr;
    assert_int_equal(pgem_create(&instance, &config), PGEM_OK);
    {
        pgem_cpp::Result<pgem_cpp::Graph2d> borrowed = pgem_cpp::Graph2d::borrow(instance);
        assert_true(borrowed.ok());
        assert_false(borrowed->owns_block());
        borrowed->add_pose(3, se2(0, 1, 0));
        assert_int_equal(pgem_cpp::Graph3d::borrow(instance).code(), PGEM_ERR_DIMENSION);
        assert_int_equal(pgem_cpp::Graph2d::borrow(nullptr).code(), PGEM_ERR_INVALID_ARGUMENT);
    }
    assert_int_equal(pgem_pose_count(instance), 1); // still alive after the wrapper is gone
    pgem_destroy(instance);
}

// ---- solving ------------------------------------------------------------------------------------

void test_robust_em(void **)
{
    pgem_cpp::Graph2d graph(pgem_cpp::Config{60, 80});
    std::uint32_t wrong[3];
    build_ring(graph, 60, 6, 3, wrong);
    uint32_t rounds = 0;
    auto count_rounds = [&rounds](const pgem_cpp::RobustProgress &progress) {
        rounds = progress.round;
    };
    pgem_cpp::RobustOptions options(PGEM_KERNEL_EM);
    options.call_each_round(count_rounds);
    const pgem_cpp::RobustSummary summary = graph.robust_optimize(options);
    assert_true(summary.usable);
    assert_int_equal(summary.loops, 12);
    assert_int_equal(summary.pruned, 3);
    assert_true(rounds >= 1);

    std::uint32_t loops = 0, pruned = 0;
    for (const auto &loop : graph.loops()) {
        const bool is_wrong = loop.index() == wrong[0] || loop.index() == wrong[1] ||
                              loop.index() == wrong[2];
        assert_int_equal(loop.state() == PGEM_LOOP_PRUNED, is_wrong);
        assert_int_equal(loop.active(), !is_wrong);
        if (!is_wrong) {
            assert_true(loop.weight() > 0.5);
        }
        pruned += !loop.active();
        loops++;
    }
    assert_int_equal(loops, 12);
    assert_int_equal(pruned, 3);

    graph.robust_reset();
    for (const auto &loop : graph.loops()) {
        assert_true(loop.active() && loop.weight() == 1.0);
    }
}

void test_callbacks(void **)
{
    pgem_cpp::Graph2d graph(pgem_cpp::Config{60, 80});
    std::uint32_t wrong[1];
    build_ring(graph, 60, 6, 0, wrong);
    const pgem_cpp::Graph2d::Pose start = graph.pose(30);

    // a callback returning a value stops the solve with true
    auto stop_after_one = [](const pgem_cpp::Iteration &iteration) {
        return iteration.iteration >= 1;
    };
    pgem_cpp::SolveOptions stopping;
    stopping.call_each_iteration(stop_after_one);
    const pgem_cpp::Summary stopped = graph.optimize(stopping);
    assert_int_equal(stopped.termination, PGEM_TERM_STOPPED);
    assert_int_equal(stopped.iterations, 1);

    // a callback returning nothing only watches
    graph.set_pose(30, start);
    std::uint32_t seen = 0;
    double last_chi2 = 0.0;
    auto watch = [&](const pgem_cpp::Iteration &iteration) {
        seen++;
        last_chi2 = iteration.chi2;
    };
    pgem_cpp::SolveOptions watching(PGEM_LEVENBERG_MARQUARDT);
    watching.call_each_iteration(watch);
    const pgem_cpp::Summary summary = graph.optimize(watching);
    assert_true(summary.converged());
    assert_int_equal(seen, summary.iterations);
    assert_true(last_chi2 >= summary.final_chi2 - 1e-9);
}

// ---- allocation ---------------------------------------------------------------------------------

void test_solve_allocates_nothing(void **)
{
    if (TEST_UNDER_SANITIZER) {
        print_message("skipped: AddressSanitizer owns malloc, so this build cannot count "
                      "allocations; the plain build runs this test\n");
        skip();
    }
    static std::array<unsigned char, 4 << 20> block;
    const long before = allocations, news_before = news;
    pgem_cpp::Graph2d graph(pgem_cpp::Config{210, 300}, block);
    std::uint32_t wrong[1];
    build_ring(graph, 200, 7, 0, wrong);
    assert_int_equal(allocations, before); // init and adding through the wrapper: nothing
    assert_int_equal(news, news_before);

    const long analysis_allocations = allocations, analysis_releases = releases;
    graph.analyze(); // CSparse's symbolic workspace: from the heap (allocated and freed here,
    // which also shows the counters see the C library's calls), or from the block when CSparse
    // is built from source
    pgem_memory_stats_t stats;
    pgem_memory_use(graph.c_handle(), &stats);
    if (stats.csparse_pool_bytes == 0) {
        assert_true(allocations > analysis_allocations);
        assert_int_equal(allocations - analysis_allocations, releases - analysis_releases);
    } else {
        assert_int_equal(allocations, analysis_allocations);
        assert_true(stats.csparse_pool_peak > 0);
    }
    const long solve_allocations = allocations, solve_releases = releases, solve_news = news;
    double sink = 0.0;
    pgem_cpp::Summary gn = graph.optimize();
    graph.set_pose(100, graph.pose(100) * se2(0.5, 0.0, 0.1));
    pgem_cpp::Summary lm = graph.optimize(pgem_cpp::SolveOptions(PGEM_LEVENBERG_MARQUARDT));
    std::uint32_t iterations = 0;
    auto count = [&iterations](const pgem_cpp::Iteration &) { iterations++; };
    pgem_cpp::SolveOptions watched;
    watched.call_each_iteration(count);
    graph.set_pose(50, graph.pose(50) * se2(0.2, 0.1, 0.0));
    pgem_cpp::Summary with_callback = graph.optimize(watched);
    pgem_cpp::RobustSummary em = graph.robust_optimize(pgem_cpp::RobustOptions(PGEM_KERNEL_EM));
    for (const auto &edge : graph.edges()) {
        sink += edge.weight() + edge.information()(0, 0) + edge.measurement().translation().x();
    }
    for (const auto &loop : graph.loops()) {
        sink += loop.weight();
    }
    for (const auto &entry : graph.poses()) {
        sink += entry.pose.translation().y();
    }
    sink += graph.chi2() + graph.edge_chi2(3);
    sink += static_cast<double>(graph.memory_stats().used_bytes);
    // the no-exception error path allocates nothing either
    const pgem_cpp::Status duplicate = graph.try_add_pose(0, se2(0, 0, 0));
    const pgem_cpp::Result<Eigen::Isometry2d> missing = graph.try_pose(123456);
    const long solve_allocations_after = allocations, solve_releases_after = releases;
    const long solve_news_after = news;

    assert_int_equal(solve_allocations_after, solve_allocations);
    assert_int_equal(solve_releases_after, solve_releases);
    assert_int_equal(solve_news_after, solve_news);
    assert_true(gn.usable && lm.usable && with_callback.usable && em.usable);
    assert_int_equal(em.pruned, 0);
    assert_true(iterations == with_callback.iterations && iterations > 0);
    assert_int_equal(duplicate.code(), PGEM_ERR_DUPLICATE_ID);
    assert_int_equal(missing.code(), PGEM_ERR_UNKNOWN_ID);
    assert_true(std::isfinite(sink));

    // the exception path does allocate (the message copy and the exception object)
    const long throwing = allocations;
    try {
        graph.add_pose(0, se2(0, 0, 0));
    } catch (const pgem_cpp::Error &error) {
        assert_int_equal(error.code(), PGEM_ERR_DUPLICATE_ID);
    }
    assert_true(allocations > throwing);
}

// ---- loading ------------------------------------------------------------------------------------

std::string temp_path(const char *name)
{
    const char *dir = std::getenv("PGEM_TEST_TMP");
    return std::string(dir != nullptr ? dir : ".") + "/" + name;
}

void write_file(const std::string &path, const char *text)
{
    std::FILE *file = std::fopen(path.c_str(), "w");
    assert_non_null(file);
    std::fputs(text, file);
    std::fclose(file);
}

void test_load(void **)
{
    const std::string path = temp_path("cpp_wrapper_triangle.g2o");
    write_file(path, "# a triangle\n"
                     "VERTEX_SE2 0 0 0 0\n"
                     "VERTEX_SE2 1 1.1 0.1 1.6\n"
                     "VERTEX_SE2 2 0.9 1.2 3.0\n"
                     "FIX 0\n"
                     "EDGE_SE2 0 1 1 0 1.5707963267948966 1 0 0 1 0 1\n"
                     "EDGE_SE2 1 2 1 0 1.5707963267948966 1 0 0 1 0 1\n"
                     "EDGE_SE2 2 0 1.4142135623730951 0 2.356194490192345 1 0 0 1 0 1\n");
    pgem_cpp::Graph2d graph = pgem_cpp::Graph2d::load(path.c_str());
    assert_true(graph.owns_block());
    assert_int_equal(graph.pose_count(), 3);
    assert_int_equal(graph.edge_count(), 3);
    assert_true(graph.pose_at(0).fixed);
    assert_int_equal(graph.edge(2).kind(), PGEM_EDGE_LOOP);
    const pgem_cpp::Summary summary = graph.optimize();
    assert_true(summary.final_chi2 < summary.initial_chi2);
    // sized exactly for the file
    assert_int_equal(graph.try_add_pose(3, se2(0, 0, 0)).code(), PGEM_ERR_CAPACITY);

    pgem_cpp::Graph2d::LoadOptions spare;
    spare.spare_poses = 2;
    spare.spare_edges = 1;
    pgem_cpp::Graph2d roomy = pgem_cpp::Graph2d::load(path.c_str(), spare);
    roomy.add_pose(3, se2(0, 0, 0));
    roomy.add_pose(4, se2(0, 0, 0));
    roomy.add_edge(3, 4, se2(0, 0, 0), diagonal3(1, 1));

    // a 2D file into a 3D graph
    const pgem_cpp::Result<pgem_cpp::Graph3d> wrong = pgem_cpp::Graph3d::try_load(path.c_str());
    assert_int_equal(wrong.code(), PGEM_ERR_DIMENSION);
    assert_contains(wrong.message(), "holds a 2D graph");
    // a missing file and a malformed line name the file (and the line)
    const std::string missing = temp_path("cpp_wrapper_missing.g2o");
    const pgem_cpp::Result<pgem_cpp::Graph2d> absent = pgem_cpp::Graph2d::try_load(missing.c_str());
    assert_int_equal(absent.code(), PGEM_ERR_IO);
    assert_contains(absent.message(), "cpp_wrapper_missing.g2o");
    const std::string broken = temp_path("cpp_wrapper_broken.g2o");
    write_file(broken, "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 x 0 0\n");
    try {
        (void)pgem_cpp::Graph2d::load(broken.c_str());
        fail_msg("no exception for a malformed line");
    } catch (const pgem_cpp::Error &error) {
        assert_int_equal(error.code(), PGEM_ERR_PARSE);
        assert_contains(error.what(), "cpp_wrapper_broken.g2o:2");
    }
    std::remove(path.c_str());
    std::remove(broken.c_str());
}

} // namespace

int main()
{
    const CMUnitTest tests[] = {
        cmocka_unit_test(test_counters_work),
        cmocka_unit_test(test_buffer_graph_2d),
        cmocka_unit_test(test_conversions_3d),
        cmocka_unit_test(test_information_from_angle_axis),
        cmocka_unit_test(test_errors_throw),
        cmocka_unit_test(test_errors_status),
        cmocka_unit_test(test_moves_and_ownership),
        cmocka_unit_test(test_robust_em),
        cmocka_unit_test(test_callbacks),
        cmocka_unit_test(test_solve_allocates_nothing),
        cmocka_unit_test(test_load),
    };
    return cmocka_run_group_tests(tests, nullptr, nullptr);
}
