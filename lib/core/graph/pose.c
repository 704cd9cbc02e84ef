/* Adding, fixing, reading and overwriting poses, each input checked before anything changes. */
#include <math.h>
#include <string.h>

#include "graph/graph.h"
#include "instance.h"

/* Field names by dimension (row 0: 2D, row 1: 3D), both rows PGEM_POSE_SIZE_MAX long. */
static const char *const pgem_pose_fields[2][PGEM_POSE_SIZE_MAX] = {
    {"x", "y", "theta", "", "", "", ""}, {"x", "y", "z", "qx", "qy", "qz", "qw"}};

/* The norm of a quaternion, left as it is. */
static double pgem_quat_norm(const double *q)
{
    double copy[4] = {q[0], q[1], q[2], q[3]};
    return pgem_quat_normalize(copy);
}

int pgem_pose_check(const double *pose, int dimension, int *field)
{
    int unused = -1;
    int *where = field != NULL ? field : &unused;
    *where = -1;
    if (pose == NULL || (dimension != 2 && dimension != 3)) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    const int size = PGEM_POSE_SIZE(dimension);
    for (int k = 0; k < size; k++) {
        if (!isfinite(pose[k])) {
            *where = k;
            return PGEM_ERR_NOT_FINITE;
        }
    }
    for (int k = 0; k < dimension; k++) { /* x, y (and z) */
        if (!(fabs(pose[k]) <= PGEM_TRANSLATION_LIMIT)) {
            *where = k;
            return PGEM_ERR_OUT_OF_RANGE;
        }
    }
    /* The norm of finite components can overflow: then it is not within tolerance either. */
    if (dimension == 3 && !(fabs(pgem_quat_norm(pose + 3) - 1.0) <= PGEM_QUAT_NORM_TOLERANCE)) {
        *where = 3;
        return PGEM_ERR_ROTATION;
    }
    return PGEM_OK;
}

int pgem_check_pose(pgem_t *graph, const double *pose, double *normalised, const char *what)
{
    const char *const *fields = pgem_pose_fields[graph->config.dimension == 3];
    int field = -1;
    int status = pgem_pose_check(pose, graph->config.dimension, &field);
    if (status != PGEM_OK) {
        pgem_message_clear(graph);
        pgem_message_text(graph, what);
        if (status == PGEM_ERR_ROTATION) {
            pgem_message_text(graph, ": quaternion (qx qy qz qw) norm is not within 1% of 1");
            return status;
        }
        pgem_message_text(graph, ": field ");
        pgem_message_text(graph, fields[field > 0 ? field : 0]); /* set with these codes */
        pgem_message_text(graph, status == PGEM_ERR_NOT_FINITE
                                     ? " is not finite"
                                     : " is beyond the translation limit (|x|, |y|, |z| at most "
                                       "1e8 m, PGEM_TRANSLATION_LIMIT)");
        return status;
    }
    memcpy(normalised, pose, (size_t)graph->pose_size * sizeof(double));
    if (graph->config.dimension == 2) {
        normalised[2] = pgem_wrap_angle(pose[2]);
        return PGEM_OK;
    }
    pgem_quat_normalize(normalised + 3);
    return PGEM_OK;
}

static int pgem_unknown_pose(pgem_t *graph, pgem_id_t id)
{
    pgem_message_clear(graph);
    pgem_message_text(graph, "no pose with id ");
    pgem_message_u64(graph, id);
    return PGEM_ERR_UNKNOWN_ID;
}

int pgem_add_pose(pgem_t *graph, pgem_id_t id, const double *pose)
{
    double checked[PGEM_POSE_SIZE_MAX];
    if (graph == NULL || pose == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (graph->store.pose_count >= graph->config.max_poses) {
        pgem_message_clear(graph);
        pgem_message_text(graph, "pose ");
        pgem_message_u64(graph, id);
        pgem_message_text(graph, " exceeds the pose capacity (max_poses = ");
        pgem_message_u64(graph, graph->config.max_poses);
        pgem_message_text(graph, ")");
        return PGEM_ERR_CAPACITY;
    }
    if (pgem_map_find(&graph->store, id) >= 0) {
        pgem_message_clear(graph);
        pgem_message_text(graph, "pose id ");
        pgem_message_u64(graph, id);
        pgem_message_text(graph, " already exists");
        return PGEM_ERR_DUPLICATE_ID;
    }
    int status = pgem_check_pose(graph, pose, checked, "pose");
    if (status != PGEM_OK) {
        pgem_message_text(graph, " (pose id ");
        pgem_message_u64(graph, id);
        pgem_message_text(graph, ")");
        return status;
    }
    uint32_t index = graph->store.pose_count;
    graph->store.pose_id[index] = id;
    memcpy(graph->store.pose + (size_t)index * (size_t)graph->pose_size, checked,
           (size_t)graph->pose_size * sizeof(double));
    graph->store.pose_fixed[index] = 0;
    pgem_map_insert(&graph->store, id, index);
    graph->store.pose_count++;
    graph->store.topology++;
    pgem_message_clear(graph);
    return PGEM_OK;
}

/* Sets pose `index`'s hold (0, PGEM_POSE_FIXED or PGEM_POSE_GAUGE). */
static void pgem_set_hold(pgem_t *graph, uint32_t index, uint8_t flag)
{
    pgem_store_t *store = &graph->store;
    if (store->pose_fixed[index] == flag) {
        return;
    }
    const uint32_t before = store->fixed_count;
    const uint32_t after = before - (store->pose_fixed[index] == PGEM_POSE_FIXED) +
                           (flag == PGEM_POSE_FIXED);
    store->pose_fixed[index] = flag;
    store->fixed_count = after;
    store->topology++;
    /* While no pose is held, the first is held in its place: the first held or the last
     * freed changes that pose too. Otherwise only this pose's column changes (none yet, for a
     * pose the incremental factor has not seen: a new part held at its gauge). */
    const uint32_t low = (before == 0u) != (after == 0u) ? 0u : index;
    store->edited_low = low < store->edited_low ? low : store->edited_low;
}

/* pgem_fix_pose and pgem_hold_gauge: the pose's index, or UNKNOWN_ID. */
static int pgem_hold(pgem_t *graph, pgem_id_t id, uint8_t flag)
{
    if (graph == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    int64_t index = pgem_map_find(&graph->store, id);
    if (index < 0) {
        return pgem_unknown_pose(graph, id);
    }
    pgem_set_hold(graph, (uint32_t)index, flag);
    pgem_message_clear(graph);
    return PGEM_OK;
}

int pgem_fix_pose(pgem_t *graph, pgem_id_t id, int fixed)
{
    return pgem_hold(graph, id, fixed ? (uint8_t)PGEM_POSE_FIXED : 0u);
}

int pgem_hold_gauge(pgem_t *graph, pgem_id_t id, int on)
{
    return pgem_hold(graph, id, on ? (uint8_t)PGEM_POSE_GAUGE : 0u);
}

int pgem_pose_index(const pgem_t *graph, pgem_id_t id, uint32_t *index)
{
    if (graph == NULL || index == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    int64_t found = pgem_map_find(&graph->store, id);
    if (found < 0) {
        return PGEM_ERR_UNKNOWN_ID;
    }
    *index = (uint32_t)found;
    return PGEM_OK;
}

int pgem_pose(const pgem_t *graph, pgem_id_t id, double *pose)
{
    if (graph == NULL || pose == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    int64_t index = pgem_map_find(&graph->store, id);
    if (index < 0) {
        return PGEM_ERR_UNKNOWN_ID;
    }
    memcpy(pose, graph->store.pose + (size_t)index * (size_t)graph->pose_size,
           (size_t)graph->pose_size * sizeof(double));
    return PGEM_OK;
}

int pgem_set_pose(pgem_t *graph, pgem_id_t id, const double *pose)
{
    double checked[PGEM_POSE_SIZE_MAX];
    if (graph == NULL || pose == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    int64_t index = pgem_map_find(&graph->store, id);
    if (index < 0) {
        return pgem_unknown_pose(graph, id);
    }
    int status = pgem_check_pose(graph, pose, checked, "pose");
    if (status != PGEM_OK) {
        pgem_message_text(graph, " (pose id ");
        pgem_message_u64(graph, id);
        pgem_message_text(graph, ")");
        return status;
    }
    memcpy(graph->store.pose + (size_t)index * (size_t)graph->pose_size, checked,
           (size_t)graph->pose_size * sizeof(double));
    graph->store.edited_low = (uint32_t)index < graph->store.edited_low ? (uint32_t)index
                                                                       : graph->store.edited_low;
    graph->store.revision++;
    pgem_message_clear(graph);
    return PGEM_OK;
}

int pgem_dimension(const pgem_t *graph)
{
    return graph != NULL ? graph->config.dimension : 0;
}

uint32_t pgem_pose_count(const pgem_t *graph)
{
    return graph != NULL ? graph->store.pose_count : 0u;
}

int pgem_pose_at(const pgem_t *graph, uint32_t index, pgem_id_t *id, double *pose, int *fixed)
{
    if (graph == NULL || index >= graph->store.pose_count) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (id != NULL) {
        *id = graph->store.pose_id[index];
    }
    if (pose != NULL) {
        memcpy(pose, graph->store.pose + (size_t)index * (size_t)graph->pose_size,
               (size_t)graph->pose_size * sizeof(double));
    }
    if (fixed != NULL) {
        *fixed = graph->store.pose_fixed[index] == PGEM_POSE_FIXED;
    }
    return PGEM_OK;
}
