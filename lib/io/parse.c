/* pgem I/O parse: turns one line of a g2o or TORO file into a pose, edge or FIX entry. */
#include <math.h>
#include <string.h>

#include "io_internal.h"

typedef enum io_line_kind { IO_VERTEX, IO_EDGE, IO_FIX, IO_EQUIV } io_line_kind_t;

/* One accepted tag: what it holds and the name of every field after it. */
typedef struct io_tag {
    const char *name;
    io_line_kind_t kind;
    int dimension;                   /* 2 or 3; 0 for FIX and EQUIV */
    pgem_format_t format;            /* the format it belongs to */
    const char *const *field_names;  /* fields after the tag, 1-based in messages */
    size_t fields;                   /* how many (FIX: at least this many) */
    size_t id_fields;                /* leading fields that are ids */
} io_tag_t;

static const char *const io_vertex_se2_fields[] = {"id", "x", "y", "th"};
static const char *const io_edge_se2_fields[] = {"i",   "j",   "dx",  "dy",  "dth", "I11",
                                                 "I12", "I13", "I22", "I23", "I33"};
static const char *const io_vertex_se3_fields[] = {"id", "x", "y", "z", "qx", "qy", "qz", "qw"};
static const char *const io_edge_se3_fields[] = {
    "i",   "j",   "x",   "y",   "z",   "qx",  "qy",  "qz",  "qw",  "I11",
    "I12", "I13", "I14", "I15", "I16", "I22", "I23", "I24", "I25", "I26",
    "I33", "I34", "I35", "I36", "I44", "I45", "I46", "I55", "I56", "I66"};
static const char *const io_vertex2_fields[] = {"id", "x", "y", "th"};
static const char *const io_edge2_fields[] = {"i",   "j",   "dx",  "dy",  "dth", "Ixx",
                                              "Ixy", "Iyy", "Itt", "Ixt", "Iyt"};
static const char *const io_fix_fields[] = {"id"};

#define IO_COUNT(array) (sizeof(array) / sizeof((array)[0]))

static const io_tag_t io_tags[] = {
    {"VERTEX_SE2", IO_VERTEX, 2, PGEM_FORMAT_G2O, io_vertex_se2_fields,
     IO_COUNT(io_vertex_se2_fields), 1},
    {"EDGE_SE2", IO_EDGE, 2, PGEM_FORMAT_G2O, io_edge_se2_fields, IO_COUNT(io_edge_se2_fields),
     2},
    {"VERTEX_SE3:QUAT", IO_VERTEX, 3, PGEM_FORMAT_G2O, io_vertex_se3_fields,
     IO_COUNT(io_vertex_se3_fields), 1},
    {"EDGE_SE3:QUAT", IO_EDGE, 3, PGEM_FORMAT_G2O, io_edge_se3_fields,
     IO_COUNT(io_edge_se3_fields), 2},
    {"FIX", IO_FIX, 0, PGEM_FORMAT_G2O, io_fix_fields, 1, 1},
    {"VERTEX2", IO_VERTEX, 2, PGEM_FORMAT_TORO, io_vertex2_fields, IO_COUNT(io_vertex2_fields),
     1},
    {"EDGE2", IO_EDGE, 2, PGEM_FORMAT_TORO, io_edge2_fields, IO_COUNT(io_edge2_fields), 2},
    {"EQUIV", IO_EQUIV, 0, PGEM_FORMAT_TORO, NULL, 0, 0},
};

/* The fields of one line after its tag, parsed. */
typedef struct io_values {
    pgem_id_t ids[2];
    double numbers[IO_FIELDS_MAX];
} io_values_t;

static const io_tag_t *io_find_tag(pgem_format_t format, const char *name)
{
    size_t i;
    for (i = 0; i < IO_COUNT(io_tags); ++i) {
        const io_tag_t *tag = &io_tags[i];
        if ((format == PGEM_FORMAT_AUTO || format == tag->format) &&
            strcmp(tag->name, name) == 0) {
            return tag;
        }
    }
    return NULL;
}

static int io_count_unknown(io_reader_t *reader, const char *name)
{
    pgem_io_graph_t *graph = reader->graph;
    if (graph->unknown_lines++ == 0) {
        io_copy_printable(graph->first_unknown_tag, sizeof graph->first_unknown_tag, name);
        graph->first_unknown_line = reader->line;
    }
    return PGEM_OK;
}

static int io_check_field_count(const io_reader_t *reader, const io_tag_t *tag, size_t count,
                                char **fields)
{
    char extra[48];
    if (count == tag->fields) {
        return PGEM_OK;
    }
    if (count < tag->fields) {
        return io_fail(reader, reader->line, PGEM_ERR_PARSE,
                       "%s has %lu fields, expected %lu (field %lu (%s) is missing)", tag->name,
                       (unsigned long)count, (unsigned long)tag->fields,
                       (unsigned long)(count + 1), tag->field_names[count]);
    }
    /* every tag has fewer than IO_FIELDS_MAX - 1 fields, so the first extra one is stored */
    io_copy_printable(extra, sizeof extra, fields[tag->fields + 1]);
    return io_fail(reader, reader->line, PGEM_ERR_PARSE,
                   "%s has %lu fields, expected %lu (field %lu '%s' is extra)", tag->name,
                   (unsigned long)count, (unsigned long)tag->fields,
                   (unsigned long)(tag->fields + 1), extra);
}

static int io_check_dimension(io_reader_t *reader, const io_tag_t *tag)
{
    pgem_io_graph_t *graph = reader->graph;
    if (graph->dimension == 0) {
        graph->dimension = tag->dimension;
        reader->dimension_line = reader->line;
        return PGEM_OK;
    }
    if (graph->dimension == tag->dimension) {
        return PGEM_OK;
    }
    return io_fail(reader, reader->line, PGEM_ERR_DIMENSION,
                   "%s is a %dD line but the file is %dD (decided by line %lu)", tag->name,
                   tag->dimension, graph->dimension, reader->dimension_line);
}

/* field is the 1-based position after the tag, named name in messages. */
static int io_parse_id_field(const io_reader_t *reader, const io_tag_t *tag, size_t field,
                             const char *name, const char *token, pgem_id_t *id)
{
    char shown[48];
    if (io_parse_id(token, id) == 0) {
        return PGEM_OK;
    }
    io_copy_printable(shown, sizeof shown, token);
    return io_fail(reader, reader->line, PGEM_ERR_PARSE,
                   "%s field %lu (%s) is not an unsigned 64-bit id: '%s'", tag->name,
                   (unsigned long)field, name, shown);
}

static int io_parse_number_field(const io_reader_t *reader, const io_tag_t *tag, size_t index,
                                 const char *token, double *value)
{
    char shown[48];
    int status = io_parse_number(token, value);
    if (status == IO_NUMBER_OK) {
        return PGEM_OK;
    }
    if (status == IO_NUMBER_NOT_FINITE) {
        return io_fail(reader, reader->line, PGEM_ERR_PARSE,
                       "%s field %lu (%s) is not a finite number", tag->name,
                       (unsigned long)(index + 1), tag->field_names[index]);
    }
    io_copy_printable(shown, sizeof shown, token);
    return io_fail(reader, reader->line, PGEM_ERR_PARSE, "%s field %lu (%s) is not a number: '%s'",
                   tag->name, (unsigned long)(index + 1), tag->field_names[index], shown);
}

/* fields[0] is the tag; fields[1 .. tag->fields] are parsed into values. */
static int io_parse_values(const io_reader_t *reader, const io_tag_t *tag, char **fields,
                           io_values_t *values)
{
    size_t i;
    int status = PGEM_OK;
    for (i = 0; i < tag->fields && status == PGEM_OK; ++i) {
        if (i < tag->id_fields) {
            status = io_parse_id_field(reader, tag, i + 1, tag->field_names[i], fields[i + 1],
                                       &values->ids[i]);
        } else {
            status = io_parse_number_field(reader, tag, i, fields[i + 1],
                                           &values->numbers[i - tag->id_fields]);
        }
    }
    return status;
}

/* A number beyond the core's magnitude limits (pgem/graph.h): the reader refuses its line, so a
 * file that reads always loads and solves with a finite chi2. index counts the numbers after
 * the ids; fields[0] is the tag. */
static int io_beyond_limit(const io_reader_t *reader, const io_tag_t *tag, char **fields,
                           size_t index, int translation)
{
    char shown[48];
    size_t field = tag->id_fields + index;
    io_copy_printable(shown, sizeof shown, fields[field + 1]);
    return io_fail(reader, reader->line, PGEM_ERR_OUT_OF_RANGE,
                   "%s field %lu (%s) is %s, beyond the %s limit (%s)", tag->name,
                   (unsigned long)(field + 1), tag->field_names[field], shown,
                   translation ? "translation" : "information",
                   translation ? "at most 1e8 m, PGEM_TRANSLATION_LIMIT"
                               : "at most 1e15, PGEM_INFORMATION_LIMIT");
}

/* The translation of a pose or measurement, and an edge's information values, within limits. */
static int io_check_magnitudes(const io_reader_t *reader, const io_tag_t *tag, char **fields,
                               const io_values_t *values)
{
    size_t k;
    size_t pose_size = (size_t)PGEM_POSE_SIZE(tag->dimension);
    for (k = 0; k < (size_t)tag->dimension; ++k) {
        if (!(fabs(values->numbers[k]) <= PGEM_TRANSLATION_LIMIT)) {
            return io_beyond_limit(reader, tag, fields, k, 1);
        }
    }
    for (k = pose_size; tag->kind == IO_EDGE && k < pose_size + io_info_values(tag->dimension);
         ++k) {
        if (!(fabs(values->numbers[k]) <= PGEM_INFORMATION_LIMIT)) {
            return io_beyond_limit(reader, tag, fields, k, 0);
        }
    }
    return PGEM_OK;
}

static int io_out_of_memory(const io_reader_t *reader)
{
    return io_fail(reader, reader->line, PGEM_ERR_OUT_OF_MEMORY, "out of memory");
}

static int io_store_vertex(io_reader_t *reader, const io_tag_t *tag, const io_values_t *values)
{
    pgem_io_pose_t *pose = io_graph_new_pose(reader->graph);
    if (pose == NULL) {
        return io_out_of_memory(reader);
    }
    pose->id = values->ids[0];
    memcpy(pose->pose, values->numbers, sizeof(double) * (size_t)PGEM_POSE_SIZE(tag->dimension));
    pose->line = reader->line;
    return PGEM_OK;
}

/* The information values after the measurement, into the full symmetric matrix. */
static void io_expand_information(const io_tag_t *tag, const double *values, double *information)
{
    size_t n = (size_t)PGEM_TANGENT_SIZE(tag->dimension);
    size_t k;
    for (k = 0; k < io_info_values(tag->dimension); ++k) {
        size_t row;
        size_t col;
        io_info_cell(tag->format, tag->dimension, k, &row, &col);
        information[row * n + col] = values[k];
        information[col * n + row] = values[k];
    }
}

static int io_store_edge(io_reader_t *reader, const io_tag_t *tag, const io_values_t *values)
{
    size_t pose_size = (size_t)PGEM_POSE_SIZE(tag->dimension);
    const int self_loop = values->ids[0] == values->ids[1]; /* kept apart: constrains nothing */
    pgem_io_edge_t *edge = self_loop ? io_graph_new_self_loop(reader->graph)
                                     : io_graph_new_edge(reader->graph);
    if (edge == NULL) {
        return io_out_of_memory(reader);
    }
    edge->from = values->ids[0];
    edge->to = values->ids[1];
    memcpy(edge->measurement, values->numbers, sizeof(double) * pose_size);
    io_expand_information(tag, values->numbers + pose_size, edge->information);
    edge->kind = io_edge_kind(edge->from, edge->to);
    edge->line = reader->line;
    if (tag->format == PGEM_FORMAT_TORO && !self_loop) {
        reader->graph->toro_edges++; /* of edge_count */
    }
    return PGEM_OK;
}

static int io_remember_fixed_line(io_reader_t *reader)
{
    void *lines = reader->fixed_lines;
    unsigned long *line = (unsigned long *)io_append(&lines, &reader->fixed_line_count,
                                                     &reader->fixed_lines_capacity, sizeof *line);
    reader->fixed_lines = (unsigned long *)lines;
    if (line == NULL) {
        return PGEM_ERR_OUT_OF_MEMORY;
    }
    *line = reader->line;
    return PGEM_OK;
}

/* FIX id [id ...]: every id is kept; checked against the poses after the last line. */
static int io_parse_fix(io_reader_t *reader, const io_tag_t *tag, char **fields, size_t count)
{
    size_t i;
    if (count == 0) {
        return io_check_field_count(reader, tag, count, fields);
    }
    if (count >= IO_FIELDS_MAX) {
        return io_fail(reader, reader->line, PGEM_ERR_PARSE, "FIX has %lu ids, at most %u per line",
                       (unsigned long)count, IO_FIELDS_MAX - 1u);
    }
    for (i = 0; i < count; ++i) {
        pgem_id_t id;
        int status = io_parse_id_field(reader, tag, i + 1, "id", fields[i + 1], &id);
        if (status != PGEM_OK) {
            return status;
        }
        if (io_graph_add_fixed(reader->graph, id) != PGEM_OK ||
            io_remember_fixed_line(reader) != PGEM_OK) {
            return io_out_of_memory(reader);
        }
    }
    return PGEM_OK;
}

static int io_parse_pose_or_edge(io_reader_t *reader, const io_tag_t *tag, char **fields,
                                 size_t count)
{
    io_values_t values = {{0}, {0}}; /* zeroed: a tag with fewer fields leaves the rest defined */
    int status = io_check_field_count(reader, tag, count, fields);
    if (status == PGEM_OK) {
        status = io_check_dimension(reader, tag);
    }
    if (status == PGEM_OK) {
        status = io_parse_values(reader, tag, fields, &values);
    }
    if (status == PGEM_OK) {
        status = io_check_magnitudes(reader, tag, fields, &values);
    }
    if (status != PGEM_OK) {
        return status;
    }
    return tag->kind == IO_VERTEX ? io_store_vertex(reader, tag, &values)
                                  : io_store_edge(reader, tag, &values);
}

int io_parse_line(io_reader_t *reader, char *text)
{
    char *fields[IO_FIELDS_MAX];
    size_t count = io_split(text, fields, IO_FIELDS_MAX);
    const io_tag_t *tag;
    if (count == 0 || fields[0][0] == '#') {
        return PGEM_OK;
    }
    tag = io_find_tag(reader->format, fields[0]);
    if (tag == NULL) {
        return io_count_unknown(reader, fields[0]);
    }
    if (tag->kind == IO_EQUIV) {
        reader->graph->equiv_lines++;
        return PGEM_OK;
    }
    if (tag->kind == IO_FIX) {
        return io_parse_fix(reader, tag, fields, count - 1);
    }
    return io_parse_pose_or_edge(reader, tag, fields, count - 1);
}
