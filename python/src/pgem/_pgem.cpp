// The binding of pgem's C API (nanobind): one instance per _Graph, numpy arrays in and out,
// every failed call raised as pgem.Error with the instance's message. The Python layer
// (pgem/__init__.py) checks shapes, converts inputs and documents the calls.
#include <cstdint>
#include <cstring>
#include <mutex>
#include <string>
#include <vector>

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>
#include <nanobind/stl/pair.h>
#include <nanobind/stl/string.h>

#include "pgem/covariance.h"
#include "pgem/io.h"
#include "pgem/pgem.h"

namespace nb = nanobind;

namespace {

using Input = nb::ndarray<const double, nb::c_contig, nb::device::cpu>;
template <typename T> using Output = nb::ndarray<nb::numpy, T>;

nb::object error_class; // pgem._error.Error, looked up at import

// Raises pgem.Error(code, name, message).
[[noreturn]] void raise_error(int code, const std::string &message)
{
    nb::object error = error_class(code, pgem_io_error_name(code), message); // the core's and lib/io's
    PyErr_SetObject(error_class.ptr(), error.ptr());
    throw nb::python_error();
}

// A zeroed numpy array of the given shape that owns its memory.
template <typename T> Output<T> make_array(std::initializer_list<size_t> shape)
{
    size_t count = 1;
    for (size_t extent : shape) {
        count *= extent;
    }
    T *data = new T[count > 0 ? count : 1]();
    nb::capsule owner(data, [](void *pointer) noexcept { delete[] static_cast<T *>(pointer); });
    return Output<T>(data, shape, owner);
}

// The robust kernel by the CLI's name.
pgem_kernel_t kernel_of(const std::string &name)
{
    if (name == "em") {
        return PGEM_KERNEL_EM;
    }
    if (name == "none") {
        return PGEM_KERNEL_NONE;
    }
    if (name == "cauchy") {
        return PGEM_KERNEL_CAUCHY;
    }
    if (name == "huber") {
        return PGEM_KERNEL_HUBER;
    }
    if (name == "dcs") {
        return PGEM_KERNEL_DCS;
    }
    raise_error(PGEM_ERR_INVALID_ARGUMENT,
                "robust must be one of em, none, cauchy, huber, dcs, got '" + name + "'");
}

// Held for every call on an instance: a Graph shared between Python threads works one call at
// a time (the long calls release the GIL, and the C instance is not safe for two at once). A
// thread that must wait waits with the GIL released, so it never blocks the holder, which needs
// the GIL back at the end of its call. Recursive: a call may use another.
class Hold {
public:
    explicit Hold(std::recursive_mutex &mutex) : mutex_(mutex)
    {
        if (!mutex_.try_lock()) {
            nb::gil_scoped_release unlocked;
            mutex_.lock();
        }
    }
    ~Hold() { mutex_.unlock(); }
    Hold(const Hold &) = delete;
    Hold &operator=(const Hold &) = delete;

private:
    std::recursive_mutex &mutex_;
};

class Graph {
public:
    Graph(int dimension, uint32_t max_poses, uint32_t max_edges, uint32_t fill_budget,
          bool online)
    {
        pgem_config_t config = {dimension, max_poses, max_edges, fill_budget, 0u, 0u};
        create(config, online);
    }

    // A graph file read into an instance of exactly its capacities.
    static Graph *read_g2o(const std::string &path, uint32_t fill_budget, bool online)
    {
        pgem_io_graph_t file;
        std::memset(&file, 0, sizeof file);
        char message[1024] = "";
        int status = pgem_io_read(path.c_str(), PGEM_FORMAT_AUTO, &file, message, sizeof message);
        if (status != PGEM_OK) {
            raise_error(status, message);
        }
        if (file.dimension == 0) {
            pgem_io_graph_free(&file);
            raise_error(PGEM_ERR_EMPTY, path + ": the file holds no graph lines");
        }
        pgem_config_t config;
        std::string skipped; // self-loops the reader left out: a warning naming their lines
        for (size_t k = 0; k < file.self_loop_count; k++) {
            skipped += (k > 0 ? ", " : "") + std::to_string(file.self_loops[k].line);
        }
        pgem_io_config(&file, &config);
        config.fill_budget = fill_budget;
        Graph *graph = nullptr;
        try {
            graph = new Graph(config, online);
        } catch (...) {
            pgem_io_graph_free(&file);
            throw;
        }
        status = pgem_io_load(&file, graph->instance_, message, sizeof message);
        pgem_io_graph_free(&file);
        if (status != PGEM_OK) {
            delete graph;
            raise_error(status, message);
        }
        if (!skipped.empty()) {
            try {
                nb::module_::import_("warnings").attr("warn")(
                    path + ": self-loop edges (a pose joined to itself constrains nothing) left "
                           "out of the graph, line(s) " + skipped);
            } catch (...) { // warnings as errors: the exception, and no graph
                delete graph;
                throw;
            }
        }
        return graph;
    }

    ~Graph() { pgem_destroy(instance_); }
    Graph(const Graph &) = delete;
    Graph &operator=(const Graph &) = delete;

    void write_g2o(const std::string &path) const
    {
        Hold hold(mutex_);
        pgem_io_graph_t file;
        std::memset(&file, 0, sizeof file);
        char message[1024] = "";
        int status = pgem_io_from_instance(instance_, &file);
        if (status == PGEM_OK) {
            status = pgem_io_write(path.c_str(), PGEM_FORMAT_G2O, &file, message, sizeof message);
        } else {
            std::snprintf(message, sizeof message, "%s", pgem_io_error_description(status));
        }
        pgem_io_graph_free(&file);
        if (status != PGEM_OK) {
            raise_error(status, message);
        }
    }

    int dimension() const { return held(pgem_dimension); }
    uint32_t pose_count() const { return held(pgem_pose_count); }
    uint32_t edge_count() const { return held(pgem_edge_count); }
    double chi2() const { return held(pgem_total_chi2); }

    void add_pose(uint64_t id, Input pose)
    {
        Hold hold(mutex_);
        check(pgem_add_pose(instance_, id, pose.data()));
    }

    void set_pose(uint64_t id, Input pose)
    {
        Hold hold(mutex_);
        check(pgem_set_pose(instance_, id, pose.data()));
    }

    Output<double> pose(uint64_t id) const
    {
        Hold hold(mutex_);
        Output<double> out = make_array<double>({pose_size()});
        check(pgem_pose(instance_, id, out.data()));
        return out;
    }

    void fix_pose(uint64_t id, bool fixed)
    {
        Hold hold(mutex_);
        check(pgem_fix_pose(instance_, id, fixed ? 1 : 0));
    }

    uint32_t add_edge(uint64_t from, uint64_t to, Input measurement, Input information, bool loop)
    {
        Hold hold(mutex_);
        uint32_t index = 0;
        check(pgem_add_edge(instance_, from, to, measurement.data(), information.data(),
                            loop ? PGEM_EDGE_LOOP : PGEM_EDGE_ODOMETRY, &index));
        return index;
    }

    // The solve; a dict of what it did.
    nb::dict optimize(const std::string &robust, double scale, const std::string &method,
                      uint32_t max_iterations)
    {
        Hold hold(mutex_);
        const pgem_kernel_t kernel = kernel_of(robust);
        pgem_solve_options_t solve;
        std::memset(&solve, 0, sizeof solve);
        if (method == "lm") {
            solve.method = PGEM_LEVENBERG_MARQUARDT;
        } else if (method != "gn") {
            raise_error(PGEM_ERR_INVALID_ARGUMENT, "method must be gn or lm, got '" + method + "'");
        }
        solve.max_iterations = max_iterations;
        nb::dict out;
        int status = PGEM_OK;
        if (kernel == PGEM_KERNEL_NONE) {
            pgem_summary_t summary;
            {
                nb::gil_scoped_release unlocked;
                pgem_robust_reset(instance_);
                status = pgem_optimize(instance_, &solve, &summary);
            }
            check(status);
            out["initial_chi2"] = summary.initial_chi2;
            out["final_chi2"] = summary.final_chi2;
            out["iterations"] = summary.iterations;
            out["rejected"] = 0u;
            out["termination"] = pgem_termination_name(summary.termination);
            out["usable"] = summary.usable != 0;
            return out;
        }
        pgem_robust_options_t options;
        std::memset(&options, 0, sizeof options);
        options.kernel = kernel;
        options.scale = scale;
        pgem_robust_summary_t summary;
        {
            nb::gil_scoped_release unlocked;
            status = pgem_robust_optimize(instance_, &options, &solve, &summary);
        }
        check(status);
        out["initial_chi2"] = summary.initial_chi2;
        out["final_chi2"] = summary.final_chi2;
        out["iterations"] = summary.gn_iterations;
        out["rejected"] = summary.rejected;
        out["loops"] = summary.loops;
        out["rounds"] = summary.rounds;
        out["em_iterations"] = summary.em_iterations;
        out["final_chi2_with_rejected"] = summary.final_chi2_all;
        out["outcome"] = pgem_robust_outcome_name(summary.outcome);
        out["termination"] = pgem_robust_termination_name(summary.termination);
        std::vector<pgem_id_t> ids(summary.parts_held);
        (void)pgem_robust_held_parts(instance_, ids.data(), summary.parts_held);
        nb::list held;
        for (pgem_id_t id : ids) {
            held.append(id);
        }
        out["held_poses"] = held;
        out["frames_placed"] = summary.frames_placed;
        out["usable"] = summary.usable != 0;
        return out;
    }

    nb::dict update(bool robust, bool rebuild)
    {
        Hold hold(mutex_);
        pgem_update_options_t options;
        std::memset(&options, 0, sizeof options);
        options.robust = robust ? 1 : 0;
        options.rebuild = rebuild ? 1 : 0;
        pgem_update_summary_t summary;
        int status = PGEM_OK;
        {
            nb::gil_scoped_release unlocked;
            status = pgem_update(instance_, &options, &summary);
        }
        check(status);
        nb::dict out;
        out["poses_added"] = summary.poses_added;
        out["edges_added"] = summary.edges_added;
        out["relinearized"] = summary.relinearized;
        out["rebuilt"] = summary.rebuilt != 0;
        out["loops_accepted"] = summary.loops_accepted;
        out["loops_rejected"] = summary.loops_rejected;
        out["loops_readmitted"] = summary.loops_readmitted;
        out["loops"] = summary.loops;
        out["loops_pruned"] = summary.loops_pruned;
        out["outcome"] = pgem_robust_outcome_name(summary.outcome);
        return out;
    }

    std::pair<Output<uint64_t>, Output<double>> poses() const
    {
        Hold hold(mutex_);
        const size_t count = pose_count(), size = pose_size();
        Output<uint64_t> ids = make_array<uint64_t>({count});
        Output<double> values = make_array<double>({count, size});
        for (uint32_t p = 0; p < count; p++) {
            pgem_id_t id = 0;
            check(pgem_pose_at(instance_, p, &id, values.data() + p * size, nullptr));
            ids.data()[p] = id;
        }
        return {ids, values};
    }

    // Every loop closure: from and to ids, weight, and 1 if pruned.
    nb::tuple loops() const
    {
        Hold hold(mutex_);
        size_t count = 0;
        pgem_edge_view_t view;
        for (uint32_t k = 0; k < edge_count(); k++) {
            check(pgem_edge_at(instance_, k, &view));
            count += view.kind == PGEM_EDGE_LOOP;
        }
        Output<uint64_t> ends = make_array<uint64_t>({count, 2});
        Output<double> weights = make_array<double>({count});
        Output<bool> pruned = make_array<bool>({count});
        size_t row = 0;
        for (uint32_t k = 0; k < edge_count(); k++) {
            check(pgem_edge_at(instance_, k, &view));
            if (view.kind != PGEM_EDGE_LOOP) {
                continue;
            }
            ends.data()[2 * row] = view.from;
            ends.data()[2 * row + 1] = view.to;
            weights.data()[row] = view.weight;
            pruned.data()[row] = view.active == 0;
            row++;
        }
        return nb::make_tuple(ends, weights, pruned);
    }

    Output<double> covariance(uint64_t id)
    {
        Hold hold(mutex_);
        const size_t n = tangent();
        Output<double> out = make_array<double>({n, n});
        with_factor([&] { return pgem_covariance(instance_, id, out.data()); });
        return out;
    }

    Output<double> joint_covariance(uint64_t a, uint64_t b)
    {
        Hold hold(mutex_);
        const size_t n = 2 * tangent();
        Output<double> out = make_array<double>({n, n});
        with_factor([&] { return pgem_joint_covariance(instance_, a, b, out.data()); });
        return out;
    }

    Output<double> covariances()
    {
        Hold hold(mutex_);
        const size_t n = tangent();
        Output<double> out = make_array<double>({static_cast<size_t>(pose_count()), n, n});
        with_factor([&] { return pgem_covariances(instance_, out.data()); });
        return out;
    }

    void prepare_covariance()
    {
        Hold hold(mutex_);
        int status = PGEM_OK;
        {
            nb::gil_scoped_release unlocked;
            status = pgem_covariance_prepare(instance_);
        }
        check(status);
    }

private:
    pgem_t *instance_ = nullptr;
    mutable std::recursive_mutex mutex_; // Hold: one call at a time

    Graph(pgem_config_t config, bool online) { create(config, online); }

    void create(pgem_config_t config, bool online)
    {
        pgem_config_t resolved;
        if (pgem_config_resolve(&config, &resolved) != PGEM_OK) {
            raise_error(PGEM_ERR_CONFIG,
                        "dimension must be 2 or 3, max_poses 1 .. 4000000 and max_edges "
                        "1 .. 16000000, got dimension " + std::to_string(config.dimension) +
                            ", max_poses " + std::to_string(config.max_poses) +
                            ", max_edges " + std::to_string(config.max_edges));
        }
        if (online) {
            resolved.online_fill = 2u * resolved.fill_budget;
        }
        const int status = pgem_create(&instance_, &resolved);
        if (status != PGEM_OK) {
            raise_error(status, std::string("cannot create the instance: ") +
                                    pgem_error_description(status));
        }
    }

    // A query of the instance, under the Hold.
    template <typename Result> Result held(Result (*query)(const pgem_t *)) const
    {
        Hold hold(mutex_);
        return query(instance_);
    }

    size_t pose_size() const { return dimension() == 3 ? 7u : 3u; }
    size_t tangent() const { return dimension() == 3 ? 6u : 3u; }

    void check(int status) const
    {
        if (status != PGEM_OK) {
            raise_error(status, pgem_last_error(instance_));
        }
    }

    // Runs a covariance call, preparing the factor first when none is current.
    template <typename Call> void with_factor(Call call)
    {
        int status = PGEM_OK;
        {
            nb::gil_scoped_release unlocked;
            status = call();
            if (status == PGEM_ERR_NO_FACTOR) {
                status = pgem_covariance_prepare(instance_);
                if (status == PGEM_OK) {
                    status = call();
                }
            }
        }
        check(status);
    }
};

} // namespace

NB_MODULE(_pgem, m)
{
    m.doc() = "pgem's C API, bound with nanobind (use the pgem package, not this module)";
    error_class = nb::module_::import_("pgem._error").attr("Error");
    m.attr("VERSION") = std::to_string(PGEM_VERSION_MAJOR) + "." +
                        std::to_string(PGEM_VERSION_MINOR) + "." +
                        std::to_string(PGEM_VERSION_PATCH);
    nb::class_<Graph>(m, "_Graph")
        .def(nb::init<int, uint32_t, uint32_t, uint32_t, bool>(), nb::arg("dimension"),
             nb::arg("max_poses"), nb::arg("max_edges"), nb::arg("fill_budget"),
             nb::arg("online"))
        .def_static("read_g2o", &Graph::read_g2o, nb::arg("path"), nb::arg("fill_budget"),
                    nb::arg("online"), nb::rv_policy::take_ownership)
        .def("write_g2o", &Graph::write_g2o, nb::arg("path"))
        .def("dimension", &Graph::dimension)
        .def("pose_count", &Graph::pose_count)
        .def("edge_count", &Graph::edge_count)
        .def("chi2", &Graph::chi2)
        .def("add_pose", &Graph::add_pose, nb::arg("id"), nb::arg("pose"))
        .def("set_pose", &Graph::set_pose, nb::arg("id"), nb::arg("pose"))
        .def("pose", &Graph::pose, nb::arg("id"))
        .def("fix_pose", &Graph::fix_pose, nb::arg("id"), nb::arg("fixed"))
        .def("add_edge", &Graph::add_edge, nb::arg("a"), nb::arg("b"), nb::arg("measurement"),
             nb::arg("information"), nb::arg("loop"))
        .def("optimize", &Graph::optimize, nb::arg("robust"), nb::arg("scale"),
             nb::arg("method"), nb::arg("max_iterations"))
        .def("update", &Graph::update, nb::arg("robust"), nb::arg("rebuild"))
        .def("poses", &Graph::poses)
        .def("loops", &Graph::loops)
        .def("covariance", &Graph::covariance, nb::arg("id"))
        .def("joint_covariance", &Graph::joint_covariance, nb::arg("a"), nb::arg("b"))
        .def("covariances", &Graph::covariances)
        .def("prepare_covariance", &Graph::prepare_covariance);
    // drop the reference at interpreter exit, before the module's statics are destroyed
    nb::module_::import_("atexit").attr("register")(nb::cpp_function([] { error_class.reset(); }));
}
