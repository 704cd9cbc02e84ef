/**
 * @file pgem/pgem.hpp
 * @brief Header-only C++17 wrapper over the pgem C API, with Eigen types in and out.
 *
 * @code
 * pgem_cpp::Graph2d graph(pgem_cpp::Config{100, 300}); // 2D, 100 poses, 300 edges (hosted)
 * graph.add_pose(0, Eigen::Isometry2d::Identity());
 * graph.add_edge(0, 1, odometry, information);          // Eigen::Isometry2d, Eigen::Matrix3d
 * pgem_cpp::Summary summary = graph.optimize();
 * Eigen::Isometry2d pose = graph.pose(1);
 * @endcode
 *
 * ### Shape
 * - Everything is in namespace `pgem_cpp` (alias it: `namespace pg = pgem_cpp;`). It cannot be
 *   `pgem`: the C API's `typedef struct pgem pgem_t` already owns the global name `pgem` in C++,
 *   and a namespace may not share a name with a class in the same scope.
 * - `pgem_cpp::Graph<2>` (alias `pgem_cpp::Graph2d`) and `pgem_cpp::Graph<3>`
 *   (`pgem_cpp::Graph3d`): one class template, the dimension a compile-time parameter, so
 *   poses are `Eigen::Isometry2d` / `Eigen::Isometry3d` and information matrices
 *   `Eigen::Matrix3d` / `Eigen::Matrix<double, 6, 6>` with no run-time dimension checks on the
 *   way in.
 * - A Graph owns one pgem instance. Hosted (`Graph(config)`, `Graph::create`): the block comes
 *   from `pgem_create` (one malloc) and is released by the destructor. Over a caller buffer
 *   (`Graph(config, buffer, size)`, `Graph::init`): `pgem_init` carves the instance from the
 *   buffer and the Graph owns nothing; the buffer must outlive it. Movable, not copyable.
 * - Options and summaries are the C structs with a zeroing constructor (zero = the documented
 *   defaults), so every field and default documented in solver.h / robust.h applies as is.
 *
 * ### 3D information convention (read this before filling a 6x6 information matrix)
 * Rows/columns are [x, y, z, rx, ry, rz] where the rotation error is the VECTOR PART OF THE
 * UNIT QUATERNION of the error rotation (g2o's convention), which is about half the rotation
 * angle. A rotation information value is therefore 4x the value for an angle-axis error (and
 * translation-rotation cross terms 2x). A standard deviation of s radians on each rotation axis
 * gives 4 / s^2 on the diagonal, not 1 / s^2. `pgem_cpp::information_from_angle_axis()`
 * converts a matrix written for an angle-axis error (GTSAM, Ceres, most papers).
 *
 * ### Errors: exceptions by default, a no-exception path for firmware
 * Every call that can fail exists twice:
 * - `graph.add_pose(...)`, `graph.optimize()`, ...: throw `pgem_cpp::Error` (a
 *   `std::runtime_error` carrying the pgem error code; `what()` is the code's name and the
 *   instance's message, e.g. "PGEM_ERR_DUPLICATE_ID: pose id 4 already exists").
 * - `graph.try_add_pose(...)`, `graph.try_optimize()`, ...: `noexcept`, return a
 *   `pgem_cpp::Status` (code + message) or a `pgem_cpp::Result<T>` (a value and a Status,
 *   like a small `std::expected`). Both are `[[nodiscard]]`.
 * When the translation unit is compiled without exceptions (`-fno-exceptions`), or defines
 * `PGEM_HPP_NO_EXCEPTIONS`, the throwing members are not declared at all, so code written for
 * firmware cannot call one by accident; `Result::value()` on an error then calls
 * `std::abort()` (check `ok()` first, or use `operator*`, which never checks).
 * Why both: exceptions are what C++ hosts expect and keep examples short, but firmware
 * toolchains commonly build with `-fno-exceptions` and must not pay for unwinding tables or
 * the heap allocation a thrown exception needs. The C codes are kept (not mapped to a C++ enum)
 * so a code reads the same in C, C++ and the documentation.
 *
 * Message lifetime: `Status::message()` points into the instance's block (the C API's
 * `pgem_last_error()`) or to static text; it stays valid until the next call on the same Graph
 * or its destruction. Copy it if it must live longer. Calls that read the graph (`pose()`,
 * `edge()`, `edge_chi2()`) cannot record a message in the C API (they take a const instance),
 * so their Status carries the code's description; the throwing versions add the id or index.
 *
 * ### Allocation
 * The wrapper allocates nothing of its own: no std::vector, std::string or std::function on
 * any path that succeeds. Poses and matrices are fixed-size Eigen objects on the stack, edge
 * and pose iteration reads the instance in place, callbacks are passed by reference through a
 * function-pointer trampoline. The only heap use is:
 * - the one block `pgem_create` mallocs for a hosted Graph (none over a caller buffer);
 * - constructing a `pgem_cpp::Error` (it copies the message into a std::string), on the error
 *   path only;
 * - `Graph::load` / `Graph::try_load`, which read a file through the hosted I/O layer
 *   (`pgem/io.h`, library pgem::pgem): the file graph is heap-allocated, then released once it
 *   is copied into the instance;
 * - what the C core itself does: CSparse's symbolic analysis mallocs and frees its workspace
 *   once per topology change (docs/design/csparse-and-exhaustion.md). `analyze()` moves it out of a
 *   time-critical loop; after it, `optimize()` and a robust solve that prunes nothing make zero
 *   allocations (tests/test_cpp_wrapper.cpp counts them).
 *
 * ### Build
 * Requires C++17 and Eigen 3.3 or newer (headers only). Link `pgem::core` for everything but
 * `Graph::load`, which needs `pgem::pgem` (the I/O library). With `PGEM_NO_MALLOC` defined
 * (the core built without `pgem_create`), the hosted constructors and `load` are left out.
 */
#ifndef PGEM_PGEM_HPP
#define PGEM_PGEM_HPP

#if !defined(PGEM_HPP_NO_EXCEPTIONS) &&                                                           \
    (defined(__cpp_exceptions) || defined(__EXCEPTIONS) || defined(_CPPUNWIND))
/** 1 when the throwing API is available (exceptions enabled, PGEM_HPP_NO_EXCEPTIONS not set). */
#define PGEM_HPP_EXCEPTIONS 1
#else
#define PGEM_HPP_EXCEPTIONS 0
#endif

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <iterator>
#include <memory>
#include <type_traits>
#include <utility>

#if PGEM_HPP_EXCEPTIONS
#include <stdexcept>
#include <string>
#endif

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "pgem/pgem.h"
#ifndef PGEM_NO_MALLOC
#include "pgem/io.h"
#endif

/** C++ wrapper of pgem; see pgem/pgem.hpp (why not `namespace pgem`: the C struct tag). */
namespace pgem_cpp {

/** Pose id (64-bit, need not be contiguous). */
using Id = pgem_id_t;
/** PGEM_EDGE_ODOMETRY or PGEM_EDGE_LOOP. */
using EdgeKind = pgem_edge_kind_t;
/** PGEM_GAUSS_NEWTON or PGEM_LEVENBERG_MARQUARDT. */
using Method = pgem_method_t;
/** PGEM_KERNEL_EM, PGEM_KERNEL_CAUCHY, ... */
using Kernel = pgem_kernel_t;
/** PGEM_LOOP_ACCEPTED or PGEM_LOOP_PRUNED. */
using LoopState = pgem_loop_state_t;
/** What one iteration of a solve reports to a callback. */
using Iteration = pgem_iteration_t;
/** What one robust round reports to a callback. */
using RobustProgress = pgem_robust_progress_t;
/** Memory diagnostics of an instance (block size, factor fill against its budget, analyses). */
using MemoryStats = pgem_memory_stats_t;

/** Capacities of a graph; its dimension is the Graph's template parameter. 0 = default. */
struct Config {
    std::uint32_t max_poses = 0;   /**< pose capacity; 0 means 1024 */
    std::uint32_t max_edges = 0;   /**< edge capacity; 0 means 4 * max_poses */
    std::uint32_t fill_budget = 0; /**< nonzeros reserved for the Cholesky factor (12 bytes
                                        each); 0 means 32 * b * b * max_poses, b = 3 or 6 */
    std::uint32_t threads = 0;     /**< workers a factorisation can use (pgem_config_t); 0 means 1 */
};

namespace detail {
/* The name and description of a status: the core's codes, and in a hosted build lib/io's too
 * (PGEM_ERR_IO, PGEM_ERR_PARSE: pgem/io.h, header only). */
inline const char *error_name(int code) noexcept {
#ifndef PGEM_NO_MALLOC
    return pgem_io_error_name(code);
#else
    return pgem_error_name(code);
#endif
}
inline const char *error_description(int code) noexcept {
#ifndef PGEM_NO_MALLOC
    return pgem_io_error_description(code);
#else
    return pgem_error_description(code);
#endif
}
} // namespace detail

/**
 * Outcome of a call: PGEM_OK, or a negative pgem error code with a message.
 * The message is never NULL; see the header's comment for how long it stays valid.
 */
class [[nodiscard]] Status {
  public:
    /** Success. */
    constexpr Status() noexcept = default;
    /** A code with its message (NULL or "" falls back to the code's description). */
    Status(int code, const char *message) noexcept
        : code_(code),
          message_(message != nullptr && message[0] != '\0'
                       ? message
                       : (code == PGEM_OK ? "" : detail::error_description(code))) {}

    /** True on success. */
    bool ok() const noexcept { return code_ == PGEM_OK; }
    /** True on success. */
    explicit operator bool() const noexcept { return ok(); }
    /** PGEM_OK (0) or a negative pgem_error_t value. */
    int code() const noexcept { return code_; }
    /** The code's constant name ("PGEM_ERR_CAPACITY"). */
    const char *name() const noexcept { return detail::error_name(code_); }
    /** What was wrong ("" on success). */
    const char *message() const noexcept { return message_; }

  private:
    int code_ = PGEM_OK;
    const char *message_ = "";
};

#if PGEM_HPP_EXCEPTIONS
/** Thrown by the throwing API: the pgem error code and the message at the time of the error. */
class Error : public std::runtime_error {
  public:
    /** Copies the status's message (this allocates; it happens only on the error path). */
    explicit Error(const Status &status)
        : std::runtime_error(std::string(status.name()) + ": " + status.message()),
          code_(status.code()) {}
    /** A code with a message of the caller's. */
    Error(int code, const std::string &message)
        : std::runtime_error(std::string(detail::error_name(code)) + ": " + message), code_(code) {}

    /** The negative pgem_error_t value. */
    int code() const noexcept { return code_; }
    /** The code's constant name ("PGEM_ERR_CAPACITY"). */
    const char *name() const noexcept { return detail::error_name(code_); }

  private:
    int code_;
};
#endif

/**
 * A value and the Status of the call that produced it (a small `std::expected`).
 * `value()` checks (throws pgem_cpp::Error, or aborts without exceptions); `operator*` and
 * `operator->` do not. For try_optimize / try_robust_optimize the summary is filled even when
 * the solve failed (it says why), so `*result` is meaningful either way.
 */
template <class T>
class [[nodiscard]] Result {
  public:
    /** Success with a value. */
    Result(T value) noexcept(std::is_nothrow_move_constructible<T>::value) // NOLINT: implicit
        : value_(std::move(value)) {}
    /** Failure (the value is default-constructed). */
    Result(Status status) noexcept(std::is_nothrow_default_constructible<T>::value) // NOLINT
        : status_(status) {}
    /** A value with the status of the call that produced it. */
    Result(T value, Status status) noexcept(std::is_nothrow_move_constructible<T>::value)
        : value_(std::move(value)), status_(status) {}

    /** True on success. */
    bool ok() const noexcept { return status_.ok(); }
    /** True on success. */
    explicit operator bool() const noexcept { return ok(); }
    /** The call's status. */
    const Status &status() const noexcept { return status_; }
    /** Shorthand for status().code(). */
    int code() const noexcept { return status_.code(); }
    /** Shorthand for status().message(). */
    const char *message() const noexcept { return status_.message(); }

    /** The value; on failure throws pgem_cpp::Error (or calls std::abort without exceptions). */
    T &value() & {
        check();
        return value_;
    }
    /** The value; on failure throws pgem_cpp::Error (or calls std::abort without exceptions). */
    const T &value() const & {
        check();
        return value_;
    }
    /** The value, moved out; on failure throws pgem_cpp::Error (or aborts without exceptions). */
    T &&value() && {
        check();
        return std::move(value_);
    }
    /** The value, unchecked. */
    T &operator*() & noexcept { return value_; }
    /** The value, unchecked. */
    const T &operator*() const & noexcept { return value_; }
    /** The value, unchecked, moved out. */
    T &&operator*() && noexcept { return std::move(value_); }
    /** Member access to the value, unchecked. */
    T *operator->() noexcept { return std::addressof(value_); }
    /** Member access to the value, unchecked. */
    const T *operator->() const noexcept { return std::addressof(value_); }

  private:
    void check() const {
        if (!status_.ok()) {
#if PGEM_HPP_EXCEPTIONS
            throw Error(status_);
#else
            std::abort();
#endif
        }
    }

    T value_{};
    Status status_;
};

namespace detail {
/* Calls a user callable from the C solver's callback: void callables never stop the solve,
 * others stop it when they return true. */
template <class F, class Argument>
int trampoline(const Argument *argument, void *context) noexcept {
    F &callback = *static_cast<F *>(context);
    if constexpr (std::is_void<decltype(callback(*argument))>::value) {
        callback(*argument);
        return 0;
    } else {
        return callback(*argument) ? 1 : 0;
    }
}

/* The C callbacks' context: the callable's address (const stripped; trampoline<F> restores F). */
template <class F>
void *context(F &callback) noexcept {
    return const_cast<void *>(static_cast<const void *>(std::addressof(callback)));
}
} // namespace detail

/** Solver options: pgem_solve_options_t zeroed (Gauss-Newton with the documented defaults). */
struct SolveOptions : pgem_solve_options_t {
    SolveOptions() noexcept : pgem_solve_options_t{} {}
    /** Zeroed options with a method. */
    explicit SolveOptions(Method solver) noexcept : pgem_solve_options_t{} { method = solver; }

    /**
     * Calls `callback(const pgem_cpp::Iteration &)` after every iteration; if it returns a value,
     * true (non-zero) stops the solve (PGEM_TERM_STOPPED). The callable is referenced, not
     * copied: it must outlive the solve. It must not throw (the C solver would be unwound;
     * the trampoline is noexcept, so a throw ends in std::terminate).
     */
    template <class F>
    SolveOptions &call_each_iteration(F &callback) noexcept {
        on_iteration = &detail::trampoline<F, pgem_iteration_t>;
        user = detail::context(callback);
        return *this;
    }
};

/** Robust options: pgem_robust_options_t zeroed. Zeroed means PGEM_KERNEL_EM with its
 * defaults, as in C and in the bridge; pass a kernel for another, e.g.
 * `pgem_cpp::RobustOptions(PGEM_KERNEL_CAUCHY)`. */
struct RobustOptions : pgem_robust_options_t {
    RobustOptions() noexcept : pgem_robust_options_t{} {}
    /** Zeroed options (documented defaults) with a kernel. */
    explicit RobustOptions(Kernel weighting) noexcept : pgem_robust_options_t{} {
        kernel = weighting;
    }

    /**
     * Calls `callback(const pgem_cpp::RobustProgress &)` after each EM round (each iteration for
     * the IRLS kernels); a true return stops. Referenced, not copied; must not throw.
     */
    template <class F>
    RobustOptions &call_each_round(F &callback) noexcept {
        on_round = &detail::trampoline<F, pgem_robust_progress_t>;
        user = detail::context(callback);
        return *this;
    }
};

/** What a solve did: pgem_summary_t with helpers. */
struct Summary : pgem_summary_t {
    Summary() noexcept : pgem_summary_t{} {}
    /** "chi2-converged", "max-iterations", ... */
    const char *termination_name() const noexcept { return pgem_termination_name(termination); }
    /** True if the solve stopped on its chi2 or step tolerance. */
    bool converged() const noexcept {
        return termination == PGEM_TERM_CHI2_CONVERGED || termination == PGEM_TERM_STEP_CONVERGED;
    }
};

/** What a robust solve did: pgem_robust_summary_t. */
struct RobustSummary : pgem_robust_summary_t {
    RobustSummary() noexcept : pgem_robust_summary_t{} {}
    /** "converged", "round_limit", "oscillated", ... (pgem_robust_termination_name). */
    const char *termination_name() const noexcept {
        return pgem_robust_termination_name(termination);
    }
};

/**
 * Converts a 6x6 information matrix written for an angle-axis rotation error [t, phi] into
 * pgem's convention [t, qvec], qvec ~= phi / 2: T * omega * T with T = diag(1, 1, 1, 2, 2, 2)
 * (rotation block x4, translation-rotation blocks x2).
 */
inline Eigen::Matrix<double, 6, 6>
information_from_angle_axis(const Eigen::Matrix<double, 6, 6> &omega) noexcept {
    Eigen::Matrix<double, 6, 1> scale;
    scale << 1.0, 1.0, 1.0, 2.0, 2.0, 2.0;
    return scale.asDiagonal() * omega * scale.asDiagonal();
}

namespace detail {

template <int Dim>
struct Traits;

template <>
struct Traits<2> {
    using Pose = Eigen::Isometry2d;
    using Information = Eigen::Matrix3d;
    static void to_array(const Pose &pose, double *out) noexcept {
        out[0] = pose.translation().x();
        out[1] = pose.translation().y();
        out[2] = std::atan2(pose.linear()(1, 0), pose.linear()(0, 0));
    }
    static Pose from_array(const double *in) noexcept {
        Pose pose = Pose::Identity();
        pose.translation() = Eigen::Vector2d(in[0], in[1]);
        pose.linear() = Eigen::Rotation2Dd(in[2]).toRotationMatrix();
        return pose;
    }
};

template <>
struct Traits<3> {
    using Pose = Eigen::Isometry3d;
    using Information = Eigen::Matrix<double, 6, 6>;
    static void to_array(const Pose &pose, double *out) noexcept {
        const Eigen::Quaterniond rotation(pose.linear());
        out[0] = pose.translation().x();
        out[1] = pose.translation().y();
        out[2] = pose.translation().z();
        out[3] = rotation.x();
        out[4] = rotation.y();
        out[5] = rotation.z();
        out[6] = rotation.w();
    }
    static Pose from_array(const double *in) noexcept {
        Pose pose = Pose::Identity();
        pose.translation() = Eigen::Vector3d(in[0], in[1], in[2]);
        pose.linear() = Eigen::Quaterniond(in[6], in[3], in[4], in[5]).toRotationMatrix();
        return pose;
    }
};

template <int Dim>
using RowMajorInformation = Eigen::Matrix<double, PGEM_TANGENT_SIZE(Dim), PGEM_TANGENT_SIZE(Dim),
                                          Eigen::RowMajor>;

#ifndef PGEM_NO_MALLOC
/* Messages of the file path (no instance to hold them): one buffer per thread, valid until the
 * next load on that thread. */
constexpr std::size_t load_message_size = 1024;

inline char *load_message() noexcept {
    thread_local char message[load_message_size];
    return message;
}
#endif

} // namespace detail

template <int Dim>
class Graph;

/** One edge as stored in the instance (a copy, read by `Graph::edge()` or iteration). */
template <int Dim>
class EdgeView {
  public:
    /** Eigen::Isometry2d or Eigen::Isometry3d. */
    using Pose = typename detail::Traits<Dim>::Pose;
    /** 3x3 or 6x6 information (see the 3D convention in the header comment). */
    using Information = typename detail::Traits<Dim>::Information;

    EdgeView() noexcept : view_{} {}

    /** Index of the edge (edges are numbered in the order added). */
    std::uint32_t index() const noexcept { return index_; }
    /** Id of the first pose. */
    Id from() const noexcept { return view_.from; }
    /** Id of the second pose. */
    Id to() const noexcept { return view_.to; }
    /** Odometry or loop closure. */
    EdgeKind kind() const noexcept { return view_.kind; }
    /** True for a loop closure. */
    bool is_loop() const noexcept { return view_.kind == PGEM_EDGE_LOOP; }
    /** Robust weight in [0, 1]; 1 for odometry and before any robust solve. */
    double weight() const noexcept { return view_.weight; }
    /** False once the robust layer pruned the loop. */
    bool active() const noexcept { return view_.active != 0; }
    /** PGEM_LOOP_PRUNED once pruned, else PGEM_LOOP_ACCEPTED. */
    LoopState state() const noexcept { return active() ? PGEM_LOOP_ACCEPTED : PGEM_LOOP_PRUNED; }
    /** The measurement: pose `to` in the frame of pose `from`. */
    Pose measurement() const noexcept { return detail::Traits<Dim>::from_array(view_.measurement); }
    /** The information matrix as given (3D: quaternion-vector rotation convention). */
    Information information() const noexcept {
        return Eigen::Map<const detail::RowMajorInformation<Dim>>(view_.information);
    }
    /** The C view. */
    const pgem_edge_view_t &c_view() const noexcept { return view_; }

  private:
    friend class Graph<Dim>;
    pgem_edge_view_t view_;
    std::uint32_t index_ = 0;
};

/** One pose as stored in the instance (a copy, read by `Graph::pose_at()` or iteration). */
template <int Dim>
struct PoseEntry {
    std::uint32_t index = 0;                          /**< insertion order */
    Id id = 0;                                        /**< its id */
    typename detail::Traits<Dim>::Pose pose;          /**< current estimate */
    bool fixed = false;                               /**< held constant by fix_pose */
};

/**
 * A pose graph of dimension Dim (2 or 3) over one pgem instance. See the header comment for
 * ownership, errors and allocation.
 */
template <int Dim>
class Graph {
    static_assert(Dim == 2 || Dim == 3, "pgem_cpp::Graph<Dim>: Dim is 2 or 3");

  public:
    /** 2 or 3. */
    static constexpr int dimension = Dim;
    /** Rows of an edge error: 3 (2D) or 6 (3D). */
    static constexpr int tangent_size = PGEM_TANGENT_SIZE(Dim);
    /** Eigen::Isometry2d or Eigen::Isometry3d. */
    using Pose = typename detail::Traits<Dim>::Pose;
    /** Eigen::Matrix3d or Eigen::Matrix<double, 6, 6>. */
    using Information = typename detail::Traits<Dim>::Information;
    /** What edge iteration yields. */
    using Edge = EdgeView<Dim>;

  private:
    /* Walks indices 0 .. count-1 of the instance, yielding each entry that reads and passes
     * the filter (nullptr: every entry), read into the iterator once per step. */
    template <class Value>
    class Range {
      public:
        /** Keeps an entry or skips it. */
        using Filter = bool (*)(const Value &) noexcept;

        /** Input iterator; dereferencing yields the current entry. */
        class iterator {
          public:
            using iterator_category = std::input_iterator_tag;
            using value_type = Value;
            using difference_type = std::ptrdiff_t;
            using pointer = const Value *;
            using reference = const Value &;

            iterator() noexcept = default;
            reference operator*() const noexcept { return value_; }
            pointer operator->() const noexcept { return &value_; }
            iterator &operator++() noexcept {
                ++index_;
                settle();
                return *this;
            }
            iterator operator++(int) noexcept {
                iterator before = *this;
                ++*this;
                return before;
            }
            bool operator==(const iterator &other) const noexcept { return index_ == other.index_; }
            bool operator!=(const iterator &other) const noexcept { return index_ != other.index_; }

          private:
            friend class Range;
            iterator(const Range &range, std::uint32_t index) noexcept
                : graph_(range.graph_), index_(index), end_(range.end_), filter_(range.filter_) {
                settle();
            }
            /* Moves to the first index from here whose entry reads and passes the filter. */
            void settle() noexcept {
                for (; index_ < end_; ++index_) {
                    if (read_at(graph_, index_, value_) == PGEM_OK &&
                        (filter_ == nullptr || filter_(value_))) {
                        return;
                    }
                }
            }
            const pgem_t *graph_ = nullptr;
            std::uint32_t index_ = 0;
            std::uint32_t end_ = 0;
            Filter filter_ = nullptr;
            Value value_;
        };

        iterator begin() const noexcept { return iterator(*this, 0); }
        iterator end() const noexcept { return iterator(*this, end_); }

      private:
        friend class Graph;
        Range(const pgem_t *graph, std::uint32_t count, Filter filter = nullptr) noexcept
            : graph_(graph), end_(count), filter_(filter) {}
        const pgem_t *graph_;
        std::uint32_t end_;
        Filter filter_;
    };

  public:
    /** Iterates the edges in index order (all, or the loop closures only). */
    using EdgeRange = Range<Edge>;
    /** Iterates the poses in insertion order, yielding pgem_cpp::PoseEntry. */
    using PoseRange = Range<PoseEntry<Dim>>;

    /** An empty Graph (no instance); only assignment, valid() and destruction are meaningful. */
    Graph() noexcept = default;
    ~Graph() { release(); }
    Graph(const Graph &) = delete;
    Graph &operator=(const Graph &) = delete;
    /** Takes the instance; `other` becomes empty. */
    Graph(Graph &&other) noexcept
        : handle_(std::exchange(other.handle_, nullptr)),
          owned_(std::exchange(other.owned_, false)) {}
    /** Releases this instance (if hosted), then takes `other`'s. */
    Graph &operator=(Graph &&other) noexcept {
        if (this != &other) {
            release();
            handle_ = std::exchange(other.handle_, nullptr);
            owned_ = std::exchange(other.owned_, false);
        }
        return *this;
    }

    // ---- construction ------------------------------------------------------------------------

    /** The C configuration for a Config at this dimension. */
    static pgem_config_t c_config(const Config &config) noexcept {
        pgem_config_t out{};
        out.dimension = Dim;
        out.max_poses = config.max_poses;
        out.max_edges = config.max_edges;
        out.fill_budget = config.fill_budget;
        out.threads = config.threads;
        return out;
    }

    /** Bytes of the block a Config needs at this dimension (0 if the config is invalid). */
    static std::size_t memory_size(const Config &config) noexcept {
        const pgem_config_t c = c_config(config);
        return pgem_memory_size(&c);
    }

    /** Initialises an instance inside `buffer` (pgem_init); nothing is allocated and the Graph
     * owns nothing: the buffer must outlive it. Errors: CONFIG, BUFFER_TOO_SMALL. */
    static Result<Graph> init(const Config &config, void *buffer, std::size_t size) noexcept {
        const pgem_config_t c = c_config(config);
        pgem_t *handle = nullptr;
        const int code = pgem_init(&handle, &c, buffer, size);
        if (code != PGEM_OK) {
            return Status(code, nullptr);
        }
        return Graph(handle, false);
    }

    /** init() over a std::array (of bytes or of any trivially copyable element). */
    template <class T, std::size_t N>
    static Result<Graph> init(const Config &config, std::array<T, N> &buffer) noexcept {
        static_assert(std::is_trivially_copyable<T>::value, "a memory block of plain data");
        return init(config, buffer.data(), sizeof buffer);
    }

    /** Wraps an instance made by C code, without owning it. Error: DIMENSION if the instance
     * is not Dim-dimensional, INVALID_ARGUMENT for NULL. */
    static Result<Graph> borrow(pgem_t *graph) noexcept {
        if (graph == nullptr) {
            return Status(PGEM_ERR_INVALID_ARGUMENT, nullptr);
        }
        if (pgem_dimension(graph) != Dim) {
            return Status(PGEM_ERR_DIMENSION, Dim == 2 ? "the instance is not 2D"
                                                       : "the instance is not 3D");
        }
        return Graph(graph, false);
    }

#ifndef PGEM_NO_MALLOC
    /** Hosted: mallocs one block of memory_size(config) (pgem_create), freed by the destructor.
     * Errors: CONFIG, OUT_OF_MEMORY. */
    static Result<Graph> create(const Config &config) noexcept {
        const pgem_config_t c = c_config(config);
        pgem_t *handle = nullptr;
        const int code = pgem_create(&handle, &c);
        if (code != PGEM_OK) {
            return Status(code, nullptr);
        }
        return Graph(handle, true);
    }
#endif

#if PGEM_HPP_EXCEPTIONS
#ifndef PGEM_NO_MALLOC
    /** Hosted: as create(), throwing pgem_cpp::Error. */
    explicit Graph(const Config &config) : Graph(create(config).value()) {}
#endif
    /** Over a caller buffer: as init(), throwing pgem_cpp::Error. */
    Graph(const Config &config, void *buffer, std::size_t size)
        : Graph(init(config, buffer, size).value()) {}
    /** Over a std::array: as init(), throwing pgem_cpp::Error. */
    template <class T, std::size_t N>
    Graph(const Config &config, std::array<T, N> &buffer) : Graph(init(config, buffer).value()) {}
#endif

    // ---- building ----------------------------------------------------------------------------

    /** Adds a pose with its initial estimate. 2D: the heading is atan2 of the linear part's
     * first column; 3D: the linear part becomes a quaternion, and one that is not a rotation
     * (norm off by more than 1%) is refused. Errors: CAPACITY, DUPLICATE_ID, NOT_FINITE,
     * ROTATION. */
    Status try_add_pose(Id id, const Pose &pose) noexcept {
        double values[PGEM_POSE_SIZE_MAX];
        detail::Traits<Dim>::to_array(pose, values);
        return status(pgem_add_pose(handle_, id, values));
    }

    /** Adds an edge: measurement of pose `to` in the frame of `from`, with its information
     * (symmetric positive definite; 3D rotation rows in the quaternion-vector convention).
     * Returns the edge's index. Errors: CAPACITY, UNKNOWN_ID, SELF_LOOP, NOT_FINITE,
     * INFORMATION, ROTATION. */
    Result<std::uint32_t> try_add_edge(Id from, Id to, const Pose &measurement,
                                       const Information &information,
                                       EdgeKind kind = PGEM_EDGE_ODOMETRY) noexcept {
        double values[PGEM_POSE_SIZE_MAX];
        detail::Traits<Dim>::to_array(measurement, values);
        const detail::RowMajorInformation<Dim> row_major = information;
        std::uint32_t index = 0;
        const int code = pgem_add_edge(handle_, from, to, values, row_major.data(), kind, &index);
        return Result<std::uint32_t>(index, status(code));
    }

    /** Holds a pose constant (or frees it). Error: UNKNOWN_ID. */
    Status try_fix_pose(Id id, bool fixed = true) noexcept {
        return status(pgem_fix_pose(handle_, id, fixed ? 1 : 0));
    }

    /** Overwrites a pose estimate. Errors: UNKNOWN_ID, NOT_FINITE, ROTATION. */
    Status try_set_pose(Id id, const Pose &pose) noexcept {
        double values[PGEM_POSE_SIZE_MAX];
        detail::Traits<Dim>::to_array(pose, values);
        return status(pgem_set_pose(handle_, id, values));
    }

    // ---- reading -----------------------------------------------------------------------------

    /** The current estimate of a pose. Error: UNKNOWN_ID. */
    Result<Pose> try_pose(Id id) const noexcept {
        double values[PGEM_POSE_SIZE_MAX];
        const int code = pgem_pose(handle_, id, values);
        if (code != PGEM_OK) {
            return Status(code, nullptr);
        }
        return detail::Traits<Dim>::from_array(values);
    }

    /** The edge at an index (0 .. edge_count()-1). Error: INVALID_ARGUMENT. */
    Result<Edge> try_edge(std::uint32_t index) const noexcept {
        Edge edge;
        const int code = read_at(handle_, index, edge);
        return Result<Edge>(edge, Status(code, nullptr));
    }

    /** The pose at an index (0 .. pose_count()-1). Error: INVALID_ARGUMENT. */
    Result<PoseEntry<Dim>> try_pose_at(std::uint32_t index) const noexcept {
        PoseEntry<Dim> entry;
        const int code = read_at(handle_, index, entry);
        if (code != PGEM_OK) {
            return Status(code, nullptr);
        }
        return entry;
    }

    /** chi2 (e^T Omega e, unweighted) of one edge under the current estimate. */
    Result<double> try_edge_chi2(std::uint32_t index) const noexcept {
        double chi2 = 0.0;
        const int code = pgem_edge_chi2(handle_, index, &chi2);
        return Result<double>(chi2, Status(code, nullptr));
    }

    /** Every edge, in index order: `for (const auto &edge : graph.edges())`. */
    EdgeRange edges() const noexcept { return EdgeRange(handle_, edge_count()); }
    /** The loop closures only, with their robust weight and state. */
    EdgeRange loops() const noexcept {
        return EdgeRange(handle_, edge_count(),
                         [](const Edge &edge) noexcept { return edge.is_loop(); });
    }
    /** Every pose, in insertion order. */
    PoseRange poses() const noexcept { return PoseRange(handle_, pose_count()); }

    /** Number of poses. */
    std::uint32_t pose_count() const noexcept { return pgem_pose_count(handle_); }
    /** Number of edges. */
    std::uint32_t edge_count() const noexcept { return pgem_edge_count(handle_); }
    /** Total chi2 (sum of e^T Omega e over all edges, unweighted). */
    double chi2() const noexcept { return pgem_total_chi2(handle_); }
    /** Memory diagnostics: block size, factor nonzeros against the budget, analyses run. */
    MemoryStats memory_stats() const noexcept {
        MemoryStats stats{};
        pgem_memory_use(handle_, &stats);
        return stats;
    }
    /** The resolved configuration (defaults filled in). */
    pgem_config_t config() const noexcept {
        const pgem_config_t *c = pgem_resolved_config(handle_);
        return c != nullptr ? *c : pgem_config_t{};
    }
    /** The message of the last failed call ("" if none). */
    const char *last_error() const noexcept { return pgem_last_error(handle_); }

    // ---- solving -----------------------------------------------------------------------------

    /** Runs the symbolic analysis now (CSparse allocates and frees its workspace here), so the
     * next solves allocate nothing. Errors: as optimize's. */
    Status try_analyze() noexcept { return status(pgem_analyze(handle_)); }

    /** Optimizes from the current estimate. On failure the estimate is restored and the summary
     * (still returned in the Result) says why. Errors: NOT_POSITIVE_DEFINITE, NUMERIC,
     * FILL_BUDGET, EMPTY, OUT_OF_MEMORY. */
    Result<Summary> try_optimize(const SolveOptions &options = SolveOptions()) noexcept {
        Summary summary;
        const int code = pgem_optimize(handle_, &options, &summary);
        return Result<Summary>(summary, status(code));
    }

    /** Robust solve (EM with pruning, Cauchy, Huber, DCS); weights and states stay on the
     * edges (see loops()). `solve` configures the Gauss-Newton M-steps. */
    Result<RobustSummary> try_robust_optimize(const RobustOptions &options,
                                              const SolveOptions &solve = SolveOptions()) noexcept {
        RobustSummary summary;
        const int code = pgem_robust_optimize(handle_, &options, &solve, &summary);
        return Result<RobustSummary>(summary, status(code));
    }

    /** Every loop weight back to 1 and every pruned loop active again. */
    void robust_reset() noexcept { pgem_robust_reset(handle_); }

#ifndef PGEM_NO_MALLOC
    /** Options of load(). */
    struct LoadOptions {
        pgem_format_t format = PGEM_FORMAT_AUTO; /**< g2o / TORO, or decided per line */
        std::uint32_t spare_poses = 0;           /**< pose capacity beyond the file's */
        std::uint32_t spare_edges = 0;           /**< edge capacity beyond the file's */
        std::uint32_t fill_budget = 0;           /**< 0 = default */
    };

    /**
     * Reads a g2o (or TORO) file into a new hosted Graph sized for it (plus spare capacity).
     * Heap: the I/O layer reads the file into a heap-allocated pgem_io_graph_t, which is freed
     * before returning; the instance is one pgem_create block. Needs pgem::pgem (pgem_io).
     * Errors: IO, PARSE, DIMENSION (a 2D file into Graph<3> or the reverse), and those of
     * adding poses and edges; the message names the file and line. It lives in a per-thread
     * buffer until the next load on the same thread.
     */
    static Result<Graph> try_load(const char *path,
                                  const LoadOptions &options = LoadOptions()) noexcept {
        char *message = detail::load_message(); /* pgem_io_read writes it on every path */
        constexpr std::size_t size = detail::load_message_size;
        pgem_io_graph_t file;
        const int code = pgem_io_read(path, options.format, &file, message, size);
        if (code != PGEM_OK) {
            return Status(code, message);
        }
        if (file.dimension != 0 && file.dimension != Dim) {
            std::snprintf(message, size,
                          "%s: the file holds a %dD graph, pgem_cpp::Graph<%d> is %dD", path,
                          file.dimension, Dim, Dim);
            pgem_io_graph_free(&file);
            return Status(PGEM_ERR_DIMENSION, message);
        }
        pgem_config_t sized;
        pgem_io_config(&file, &sized);
        Config config;
        config.max_poses = add_capacity(sized.max_poses, options.spare_poses);
        config.max_edges = add_capacity(sized.max_edges, options.spare_edges);
        config.fill_budget = options.fill_budget;
        Result<Graph> graph = create(config);
        if (graph.ok()) {
            const int loaded = pgem_io_load(&file, graph->handle_, message, size);
            if (loaded != PGEM_OK) {
                graph = Status(loaded, message); /* releases the half-loaded instance */
            }
        }
        pgem_io_graph_free(&file);
        return graph;
    }
#endif

#if PGEM_HPP_EXCEPTIONS
    /** try_add_pose, throwing pgem_cpp::Error. */
    void add_pose(Id id, const Pose &pose) { raise(try_add_pose(id, pose)); }
    /** try_add_edge, throwing pgem_cpp::Error; returns the edge's index. */
    std::uint32_t add_edge(Id from, Id to, const Pose &measurement, const Information &information,
                           EdgeKind kind = PGEM_EDGE_ODOMETRY) {
        return try_add_edge(from, to, measurement, information, kind).value();
    }
    /** try_fix_pose, throwing pgem_cpp::Error. */
    void fix_pose(Id id, bool fixed = true) { raise(try_fix_pose(id, fixed)); }
    /** try_set_pose, throwing pgem_cpp::Error. */
    void set_pose(Id id, const Pose &pose) { raise(try_set_pose(id, pose)); }
    /** try_pose, throwing pgem_cpp::Error naming the id. */
    Pose pose(Id id) const {
        Result<Pose> result = try_pose(id);
        if (!result.ok()) {
            throw Error(result.code(), "no pose with id " + std::to_string(id));
        }
        return *result;
    }
    /** try_edge, throwing pgem_cpp::Error naming the index. */
    Edge edge(std::uint32_t index) const {
        return or_out_of_range(try_edge(index), "edge", index, edge_count());
    }
    /** try_pose_at, throwing pgem_cpp::Error naming the index. */
    PoseEntry<Dim> pose_at(std::uint32_t index) const {
        return or_out_of_range(try_pose_at(index), "pose", index, pose_count());
    }
    /** try_edge_chi2, throwing pgem_cpp::Error naming the index. */
    double edge_chi2(std::uint32_t index) const {
        return or_out_of_range(try_edge_chi2(index), "edge", index, edge_count());
    }
    /** try_analyze, throwing pgem_cpp::Error. */
    void analyze() { raise(try_analyze()); }
    /** try_optimize, throwing pgem_cpp::Error (the estimate is restored first). */
    Summary optimize(const SolveOptions &options = SolveOptions()) {
        return try_optimize(options).value();
    }
    /** try_robust_optimize, throwing pgem_cpp::Error (the estimate is restored first). */
    RobustSummary robust_optimize(const RobustOptions &options,
                                  const SolveOptions &solve = SolveOptions()) {
        return try_robust_optimize(options, solve).value();
    }
#ifndef PGEM_NO_MALLOC
    /** try_load, throwing pgem_cpp::Error. */
    static Graph load(const char *path, const LoadOptions &options = LoadOptions()) {
        return try_load(path, options).value();
    }
#endif
#endif

    // ---- the C side --------------------------------------------------------------------------

    /** True if the Graph holds an instance (false when default-constructed or moved from). */
    bool valid() const noexcept { return handle_ != nullptr; }
    /** True if the destructor frees the block (hosted); false over a caller buffer. */
    bool owns_block() const noexcept { return owned_; }
    /** The C instance, for calls the wrapper does not cover. */
    pgem_t *c_handle() noexcept { return handle_; }
    /** The C instance, for calls the wrapper does not cover. */
    const pgem_t *c_handle() const noexcept { return handle_; }

  private:
    Graph(pgem_t *handle, bool owned) noexcept : handle_(handle), owned_(owned) {}

    void release() noexcept {
#ifndef PGEM_NO_MALLOC
        if (owned_) {
            pgem_destroy(handle_);
        }
#endif
        handle_ = nullptr;
        owned_ = false;
    }

    /* The status of a call that records its message in the instance. */
    Status status(int code) const noexcept {
        return code == PGEM_OK ? Status() : Status(code, pgem_last_error(handle_));
    }

    /* Reads the entry at an index into `out` (the C code: INVALID_ARGUMENT out of range). */
    static int read_at(const pgem_t *graph, std::uint32_t index, Edge &out) noexcept {
        out.index_ = index;
        return pgem_edge_at(graph, index, &out.view_);
    }
    static int read_at(const pgem_t *graph, std::uint32_t index, PoseEntry<Dim> &out) noexcept {
        Id id = 0;
        double values[PGEM_POSE_SIZE_MAX];
        int fixed = 0;
        const int code = pgem_pose_at(graph, index, &id, values, &fixed);
        if (code == PGEM_OK) {
            out.index = index;
            out.id = id;
            out.pose = detail::Traits<Dim>::from_array(values);
            out.fixed = fixed != 0;
        }
        return code;
    }

#ifndef PGEM_NO_MALLOC
    static std::uint32_t add_capacity(std::uint32_t base, std::uint32_t spare) noexcept {
        const std::uint64_t total = static_cast<std::uint64_t>(base) + spare;
        return total > UINT32_MAX ? UINT32_MAX : static_cast<std::uint32_t>(total);
    }
#endif

#if PGEM_HPP_EXCEPTIONS
    static void raise(const Status &status) {
        if (!status.ok()) {
            throw Error(status);
        }
    }
    /* The value of an index-based read, or Error "<what> index 7 is out of range (3 <what>s)". */
    template <class T>
    static T or_out_of_range(Result<T> &&result, const char *what, std::uint32_t index,
                             std::uint32_t count) {
        if (!result.ok()) {
            throw Error(result.code(), std::string(what) + " index " + std::to_string(index) +
                                           " is out of range (" + std::to_string(count) + " " +
                                           what + "s)");
        }
        return *std::move(result);
    }
#endif

    pgem_t *handle_ = nullptr;
    bool owned_ = false;
};

/** A 2D pose graph: Eigen::Isometry2d poses, Eigen::Matrix3d information. */
using Graph2d = Graph<2>;
/** A 3D pose graph: Eigen::Isometry3d poses, Eigen::Matrix<double, 6, 6> information. */
using Graph3d = Graph<3>;

} // namespace pgem_cpp

#endif /* PGEM_PGEM_HPP */
