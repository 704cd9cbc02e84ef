/* pgem plot: the picture cmd_plot.c builds from the files (lines in world coordinates, one
 * entry per graph) and plot_svg.c draws. */
#ifndef PGEM_PLOT_H
#define PGEM_PLOT_H

#include <stddef.h>
#include <stdio.h>

/* What a line stands for; decides its colour, width and dash. */
typedef enum plot_style {
    PLOT_TRUTH = 0,        /* ground truth trajectory, grey */
    PLOT_ODOMETRY,         /* odometry chain, blue */
    PLOT_ACCEPTED,         /* loop closure accepted (a true one, when the outliers are known) */
    PLOT_TRUE_REJECTED,    /* a true loop closure rejected (outliers known) */
    PLOT_REJECTED,         /* loop closure rejected (a false one, when the outliers are known) */
    PLOT_MISSED,           /* a false loop closure accepted */
    PLOT_STYLE_COUNT
} plot_style_t;

/* Strokes in world coordinates: each point either starts a stroke or continues the last. */
typedef struct plot_lines {
    double (*points)[3];
    unsigned char *starts;       /* 1: move to the point; 0: draw a line to it */
    size_t count;
    size_t capacity;
    size_t strokes;              /* points that start a stroke */
} plot_lines_t;

/* One graph: a panel in 2D, a top (x-y) and a side (x-z) panel in 3D. */
typedef struct plot_graph {
    char caption[160];           /* above its panels ("" for none) */
    plot_lines_t lines[PLOT_STYLE_COUNT];
} plot_graph_t;

typedef struct plot_figure {
    int dimension;               /* 2 or 3 */
    double width;                /* pixels */
    char title[256];
    char subtitle[256];
    size_t graph_count;          /* 1, or 2 for a before/after pair (before first) */
    plot_graph_t graphs[2];
    char legend[PLOT_STYLE_COUNT][160]; /* text of each legend entry ("" for none) */
} plot_figure_t;

/* Appends a point; returns 0 when out of memory. */
int plot_lines_add(plot_lines_t *lines, const double point[3], int start);

void plot_figure_free(plot_figure_t *figure);

/* Writes the figure as one SVG document. Returns 0, or -1 when the stream reports an error. */
int plot_write_svg(const plot_figure_t *figure, FILE *out);

#endif /* PGEM_PLOT_H */
