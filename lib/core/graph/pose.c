/* Adding, fixing, reading and overwriting poses, each input checked before anything changes
 * (the public pose calls are these over the instance's store, instance/graph.c). */
#include <math.h>
#include <string.h>

#include "graph/graph.h"

/* Field names by dimension (row 0: 2D, row 1: 3D), both rows PGEM_POSE_SIZE_MAX long. */
static const char *const pgem_pose_fields[2][PGEM_POSE_SIZE_MAX] = {
    {"x", "y", "theta", "", "", "", ""}, {"x", "y", "z", "qx", "qy", "qz", "qw"}};

static void pgem_pose_note(char *message, const char *text)
{
    pgem_text_append(message, PGEM_MESSAGE_SIZE, text);
}

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

int pgem_check_pose(char *message, int dimension, const double *pose, double *normalised,
                    const char *what)
{
    const char *const *fields = pgem_pose_fields[dimension == 3];
    int field = -1;
    int status = pgem_pose_check(pose, dimension, &field);
    if (status != PGEM_OK) {
        message[0] = '\0';
        pgem_pose_note(message, what);
        if (status == PGEM_ERR_ROTATION) {
            pgem_pose_note(message, ": quaternion (qx qy qz qw) norm is not within 1% of 1");
            return status;
        }
        pgem_pose_note(message, ": field ");
        pgem_pose_note(message, fields[field > 0 ? field : 0]); /* set with these codes */
        pgem_pose_note(message, status == PGEM_ERR_NOT_FINITE
                                    ? " is not finite"
                                    : " is beyond the translation limit (|x|, |y|, |z| at most "
                                      "1e8 m, PGEM_TRANSLATION_LIMIT)");
        return status;
    }
    memcpy(normalised, pose, (size_t)PGEM_POSE_SIZE(dimension) * sizeof(double));
    if (dimension == 2) {
        normalised[2] = pgem_wrap_angle(pose[2]);
        return PGEM_OK;
    }
    pgem_quat_normalize(normalised + 3);
    return PGEM_OK;
}

static int pgem_unknown_pose(pgem_id_t id, char *message)
{
    message[0] = '\0';
    pgem_pose_note(message, "no pose with id ");
    pgem_text_u64(message, PGEM_MESSAGE_SIZE, id);
    return PGEM_ERR_UNKNOWN_ID;
}

/* " (pose id ID)" after a refused pose's message. */
static int pgem_pose_fail_id(int status, pgem_id_t id, char *message)
{
    pgem_pose_note(message, " (pose id ");
    pgem_text_u64(message, PGEM_MESSAGE_SIZE, id);
    pgem_pose_note(message, ")");
    return status;
}

int pgem_store_add_pose(pgem_store_t *store, const pgem_config_t *config, pgem_id_t id,
                        const double *pose, char *message)
{
    double checked[PGEM_POSE_SIZE_MAX];
    if (pose == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (store->pose_count >= config->max_poses) {
        message[0] = '\0';
        pgem_pose_note(message, "pose ");
        pgem_text_u64(message, PGEM_MESSAGE_SIZE, id);
        pgem_pose_note(message, " exceeds the pose capacity (max_poses = ");
        pgem_text_u64(message, PGEM_MESSAGE_SIZE, config->max_poses);
        pgem_pose_note(message, ")");
        return PGEM_ERR_CAPACITY;
    }
    if (pgem_map_find(store, id) >= 0) {
        message[0] = '\0';
        pgem_pose_note(message, "pose id ");
        pgem_text_u64(message, PGEM_MESSAGE_SIZE, id);
        pgem_pose_note(message, " already exists");
        return PGEM_ERR_DUPLICATE_ID;
    }
    int status = pgem_check_pose(message, config->dimension, pose, checked, "pose");
    if (status != PGEM_OK) {
        return pgem_pose_fail_id(status, id, message);
    }
    const size_t size = (size_t)PGEM_POSE_SIZE(config->dimension);
    uint32_t index = store->pose_count;
    store->pose_id[index] = id;
    memcpy(store->pose + (size_t)index * size, checked, size * sizeof(double));
    store->pose_fixed[index] = 0;
    pgem_map_insert(store, id, index);
    store->pose_count++;
    store->topology++;
    message[0] = '\0';
    return PGEM_OK;
}

/* Sets pose `index`'s hold (0, PGEM_POSE_FIXED or PGEM_POSE_GAUGE). */
static void pgem_set_hold(pgem_store_t *store, uint32_t index, uint8_t flag)
{
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

int pgem_store_hold(pgem_store_t *store, pgem_id_t id, uint8_t flag, char *message)
{
    int64_t index = pgem_map_find(store, id);
    if (index < 0) {
        return pgem_unknown_pose(id, message);
    }
    pgem_set_hold(store, (uint32_t)index, flag);
    message[0] = '\0';
    return PGEM_OK;
}

int pgem_store_pose_index(const pgem_store_t *store, pgem_id_t id, uint32_t *index)
{
    if (index == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    int64_t found = pgem_map_find(store, id);
    if (found < 0) {
        return PGEM_ERR_UNKNOWN_ID;
    }
    *index = (uint32_t)found;
    return PGEM_OK;
}

int pgem_store_pose(const pgem_store_t *store, int dimension, pgem_id_t id, double *pose)
{
    if (pose == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    int64_t index = pgem_map_find(store, id);
    if (index < 0) {
        return PGEM_ERR_UNKNOWN_ID;
    }
    const size_t size = (size_t)PGEM_POSE_SIZE(dimension);
    memcpy(pose, store->pose + (size_t)index * size, size * sizeof(double));
    return PGEM_OK;
}

int pgem_store_set_pose(pgem_store_t *store, int dimension, pgem_id_t id, const double *pose,
                        char *message)
{
    double checked[PGEM_POSE_SIZE_MAX];
    if (pose == NULL) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    int64_t index = pgem_map_find(store, id);
    if (index < 0) {
        return pgem_unknown_pose(id, message);
    }
    int status = pgem_check_pose(message, dimension, pose, checked, "pose");
    if (status != PGEM_OK) {
        return pgem_pose_fail_id(status, id, message);
    }
    const size_t size = (size_t)PGEM_POSE_SIZE(dimension);
    memcpy(store->pose + (size_t)index * size, checked, size * sizeof(double));
    store->edited_low = (uint32_t)index < store->edited_low ? (uint32_t)index : store->edited_low;
    store->revision++;
    message[0] = '\0';
    return PGEM_OK;
}

int pgem_store_pose_at(const pgem_store_t *store, int dimension, uint32_t index, pgem_id_t *id,
                       double *pose, int *fixed)
{
    if (index >= store->pose_count) {
        return PGEM_ERR_INVALID_ARGUMENT;
    }
    if (id != NULL) {
        *id = store->pose_id[index];
    }
    if (pose != NULL) {
        const size_t size = (size_t)PGEM_POSE_SIZE(dimension);
        memcpy(pose, store->pose + (size_t)index * size, size * sizeof(double));
    }
    if (fixed != NULL) {
        *fixed = store->pose_fixed[index] == PGEM_POSE_FIXED;
    }
    return PGEM_OK;
}
