/* pgem plot, drawing: lays the panels out on a grid (a 2D graph per column; a 3D graph per
 * row, its top and side views side by side), keeps an equal aspect ratio with one scale per
 * graph, draws each kind of line as one <path> per panel, a scale bar per graph, the title and
 * a legend. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "plot.h"

#define SVG_MARGIN 16.0         /* around the picture */
#define SVG_GAP 28.0            /* between two grid columns */
#define SVG_PAD 12.0            /* inside a panel's frame */
#define SVG_MIN_PANEL 48.0      /* smallest panel height (a flat side view) */
#define SVG_TITLE_SIZE 20.0     /* font sizes */
#define SVG_TEXT_SIZE 13.0
#define SVG_CHAR_WIDTH 7.2      /* a generous average advance at SVG_TEXT_SIZE */
#define SVG_SWATCH 30.0         /* legend line length */
#define SVG_ROW 20.0            /* legend row and caption height */
#define SVG_SCALE_ROW 30.0      /* scale bar row height */
#define SVG_RING 7.0            /* radius of the rings around rare loops, pixels */
#define SVG_MIN_STEP 0.5        /* chain points closer than this (px) to the last are skipped */

/* How one kind of line is drawn. */
typedef struct svg_style {
    const char *name;            /* the class attribute of its <path> */
    const char *colour;
    double width;                /* times the graph's base width */
    double min_width;            /* pixels */
    double opacity;
    const char *dash;            /* stroke-dasharray, or NULL */
} svg_style_t;

static const svg_style_t svg_styles[PLOT_STYLE_COUNT] = {
    [PLOT_TRUTH] = {"truth", "#a0a0a0", 2.5, 0.8, 0.7, NULL},
    [PLOT_ODOMETRY] = {"odometry", "#1f4fd1", 1.0, 0.0, 1.0, NULL},
    [PLOT_ACCEPTED] = {"accepted", "#2ca02c", 1.0, 0.0, 0.8, NULL},
    [PLOT_TRUE_REJECTED] = {"true-rejected", "#ff8c00", 1.5, 0.9, 1.0, "5 3"},
    [PLOT_REJECTED] = {"rejected", "#d62728", 1.0, 0.5, 0.75, NULL},
    [PLOT_MISSED] = {"missed", "#c000c0", 2.5, 1.5, 1.0, NULL},
};

/* Bottom to top: what matters most last. */
static const plot_style_t svg_order[PLOT_STYLE_COUNT] = {
    PLOT_TRUTH, PLOT_ACCEPTED, PLOT_ODOMETRY, PLOT_TRUE_REJECTED, PLOT_REJECTED, PLOT_MISSED};

/* Legend order: the trajectory, then the loops from good to bad. */
static const plot_style_t svg_legend_order[PLOT_STYLE_COUNT] = {
    PLOT_ODOMETRY, PLOT_TRUTH, PLOT_ACCEPTED, PLOT_REJECTED, PLOT_TRUE_REJECTED, PLOT_MISSED};

/* A projection: x across, y (top view) or z (side view) up. */
typedef struct svg_view {
    int axis;                    /* 1: y, 2: z */
    const char *name;
} svg_view_t;

static const svg_view_t svg_views[2] = {{1, "top (x-y)"}, {2, "side (x-z)"}};

/* The scale of one graph, shared by its views. */
typedef struct svg_graph {
    double scale;                /* pixels per metre */
    double low[3], high[3];      /* bounds of its lines, metres */
    double line_width;           /* base stroke width, pixels */
} svg_graph_t;

/* The whole layout. */
typedef struct svg_layout {
    size_t views;                /* 1 (2D) or 2 (3D) */
    size_t grid_columns, grid_rows;
    double column_width;
    double inner;                /* column width less the padding */
    int captions;                /* panels have captions */
    double row_top[2];           /* top of each grid row's panels */
    double row_height[2];
    double legend_top;
    double height;
    svg_graph_t graphs[2];
} svg_layout_t;

/* Pixel mapping of one panel. */
typedef struct svg_map {
    double left, top;            /* the panel's frame */
    double x0, y0;               /* pixel of the bounds' centre */
    double cx, cy;               /* world centre of the bounds */
    double scale;
    int axis;
} svg_map_t;

int plot_lines_add(plot_lines_t *lines, const double point[3], int start)
{
    if (lines->count == lines->capacity) {
        size_t grown = lines->capacity < 64u ? 64u : 2u * lines->capacity;
        double(*points)[3] = realloc(lines->points, grown * sizeof *points);
        if (points == NULL) {
            return 0;
        }
        lines->points = points;
        unsigned char *starts = realloc(lines->starts, grown);
        if (starts == NULL) {
            return 0;
        }
        lines->starts = starts;
        lines->capacity = grown;
    }
    memcpy(lines->points[lines->count], point, sizeof lines->points[0]);
    lines->starts[lines->count++] = (unsigned char)(start != 0);
    lines->strokes += (size_t)(start != 0);
    return 1;
}

void plot_figure_free(plot_figure_t *figure)
{
    for (size_t g = 0; g < 2u; g++) {
        for (int s = 0; s < PLOT_STYLE_COUNT; s++) {
            free(figure->graphs[g].lines[s].points);
            free(figure->graphs[g].lines[s].starts);
            memset(&figure->graphs[g].lines[s], 0, sizeof figure->graphs[g].lines[s]);
        }
    }
}

/* Grid row and column of a view of a graph. */
static size_t svg_row(const svg_layout_t *layout, size_t g)
{
    return layout->views > 1u ? g : 0u;
}

static size_t svg_column(const svg_layout_t *layout, size_t g, size_t v)
{
    return layout->views > 1u ? v : g;
}

/* Bounds of every line of a graph (0 when it has none). */
static void svg_bounds(const plot_graph_t *graph, svg_graph_t *out)
{
    int any = 0;
    for (int s = 0; s < PLOT_STYLE_COUNT; s++) {
        const plot_lines_t *lines = &graph->lines[s];
        for (size_t k = 0; k < lines->count; k++) {
            for (int d = 0; d < 3; d++) {
                double v = lines->points[k][d];
                out->low[d] = any && out->low[d] < v ? out->low[d] : v;
                out->high[d] = any && out->high[d] > v ? out->high[d] : v;
            }
            any = 1;
        }
    }
    if (!any) {
        memset(out->low, 0, sizeof out->low);
        memset(out->high, 0, sizeof out->high);
    }
}

/* Pixels per metre fitting every view of a graph into inner x inner pixels at most. */
static double svg_scale(const svg_graph_t *graph, size_t views, double inner)
{
    double scale = HUGE_VAL;
    double x_range = graph->high[0] - graph->low[0];
    if (x_range > 0.0) {
        scale = inner / x_range;
    }
    for (size_t v = 0; v < views; v++) {
        int axis = svg_views[v].axis;
        double range = graph->high[axis] - graph->low[axis];
        if (range > 0.0 && inner / range < scale) {
            scale = inner / range;
        }
    }
    return isfinite(scale) ? scale : inner; /* a single point: 1 m across the panel */
}

/* Base stroke width: an eighth of the mean spacing between odometry lines in the first view
 * (panel area / chain length), between 0.3 and 1.5 pixels, so a dense graph gets thin lines. */
static double svg_line_width(const plot_graph_t *graph, double scale, double area)
{
    const plot_lines_t *odometry = &graph->lines[PLOT_ODOMETRY];
    double length = 0.0;
    for (size_t k = 1; k < odometry->count; k++) {
        if (!odometry->starts[k]) {
            double dx = odometry->points[k][0] - odometry->points[k - 1u][0];
            double dy = odometry->points[k][1] - odometry->points[k - 1u][1];
            length += sqrt(dx * dx + dy * dy) * scale;
        }
    }
    double width = length > 0.0 ? 0.125 * area / length : 1.5;
    return width < 0.3 ? 0.3 : width > 1.5 ? 1.5 : width;
}

/* Text content with &, <, > and " escaped and control characters dropped. */
static void svg_text(FILE *out, const char *text)
{
    for (const unsigned char *c = (const unsigned char *)text; *c != '\0'; c++) {
        if (*c == '&') {
            fputs("&amp;", out);
        } else if (*c == '<') {
            fputs("&lt;", out);
        } else if (*c == '>') {
            fputs("&gt;", out);
        } else if (*c == '"') {
            fputs("&quot;", out);
        } else if (*c >= 0x20u) {
            fputc(*c, out);
        }
    }
}

static void svg_label(FILE *out, double x, double y, const char *fill, double size,
                      const char *text)
{
    fprintf(out, "<text x=\"%.1f\" y=\"%.1f\" font-size=\"%.0f\" fill=\"%s\">", x, y, size, fill);
    svg_text(out, text);
    fputs("</text>\n", out);
}

/* Stroke attributes of a style at a base width. */
static void svg_stroke(FILE *out, plot_style_t style, double base)
{
    const svg_style_t *s = &svg_styles[style];
    double width = s->width * base;
    width = width < s->min_width ? s->min_width : width;
    fprintf(out, "fill=\"none\" stroke=\"%s\" stroke-width=\"%.2f\" stroke-linecap=\"round\" "
                 "stroke-linejoin=\"round\"", s->colour, width);
    if (s->opacity < 1.0) {
        fprintf(out, " stroke-opacity=\"%.2f\"", s->opacity);
    }
    if (s->dash != NULL) {
        fprintf(out, " stroke-dasharray=\"%s\"", s->dash);
    }
}

/* Lays the legend entries out in rows from `top` and draws them when out is not NULL;
 * returns the number of rows. */
static size_t svg_legend(FILE *out, const plot_figure_t *figure, double top)
{
    double available = figure->width - 2.0 * SVG_MARGIN, x = available;
    double y = top - SVG_ROW;
    size_t rows = 0;
    for (int k = 0; k < PLOT_STYLE_COUNT; k++) {
        plot_style_t style = svg_legend_order[k];
        const char *text = figure->legend[style];
        if (text[0] == '\0') {
            continue;
        }
        double entry = SVG_SWATCH + 6.0 + SVG_CHAR_WIDTH * (double)strlen(text);
        if (x + entry > available) {
            x = 0.0;
            y += SVG_ROW;
            rows++;
        }
        double left = SVG_MARGIN + x, middle = y + 0.5 * SVG_ROW;
        x += entry + 18.0;
        if (out == NULL) {
            continue;
        }
        fprintf(out, "<path class=\"legend-%s\" ", svg_styles[style].name);
        svg_stroke(out, style, 1.5);
        fprintf(out, " d=\"M%.1f %.1fh%.1f\"/>\n", left, middle, SVG_SWATCH);
        svg_label(out, left + SVG_SWATCH + 6.0, middle + 4.5, "#000", SVG_TEXT_SIZE, text);
    }
    return rows;
}

static void svg_layout(const plot_figure_t *figure, svg_layout_t *layout)
{
    memset(layout, 0, sizeof *layout);
    layout->views = figure->dimension == 3 ? 2u : 1u;
    layout->grid_columns = layout->views > 1u ? layout->views : figure->graph_count;
    layout->grid_rows = layout->views > 1u ? figure->graph_count : 1u;
    layout->column_width = (figure->width - 2.0 * SVG_MARGIN -
                            (double)(layout->grid_columns - 1u) * SVG_GAP) /
                           (double)layout->grid_columns;
    layout->inner = layout->column_width - 2.0 * SVG_PAD;
    layout->captions = layout->grid_columns > 1u || layout->grid_rows > 1u;
    for (size_t g = 0; g < figure->graph_count; g++) {
        svg_graph_t *graph = &layout->graphs[g];
        size_t row = svg_row(layout, g);
        svg_bounds(&figure->graphs[g], graph);
        graph->scale = svg_scale(graph, layout->views, layout->inner);
        for (size_t v = 0; v < layout->views; v++) {
            int axis = svg_views[v].axis;
            double height = (graph->high[axis] - graph->low[axis]) * graph->scale + 2.0 * SVG_PAD;
            height = height < SVG_MIN_PANEL ? SVG_MIN_PANEL : height;
            layout->row_height[row] = height > layout->row_height[row] ? height
                                                                       : layout->row_height[row];
        }
    }
    for (size_t g = 0; g < figure->graph_count; g++) {
        double area = layout->column_width * layout->row_height[svg_row(layout, g)];
        layout->graphs[g].line_width =
            svg_line_width(&figure->graphs[g], layout->graphs[g].scale, area);
    }
    double y = SVG_MARGIN + SVG_TITLE_SIZE + 8.0 + SVG_TEXT_SIZE + 12.0;
    for (size_t r = 0; r < layout->grid_rows; r++) {
        y += layout->captions ? SVG_ROW : 0.0;
        layout->row_top[r] = y;
        y += layout->row_height[r] + SVG_SCALE_ROW;
    }
    layout->legend_top = y;
    size_t rows = svg_legend(NULL, figure, layout->legend_top);
    layout->height = layout->legend_top + (double)rows * SVG_ROW + SVG_MARGIN;
}

static svg_map_t svg_mapping(const svg_layout_t *layout, size_t g, size_t v)
{
    const svg_graph_t *graph = &layout->graphs[g];
    size_t row = svg_row(layout, g), column = svg_column(layout, g, v);
    int axis = svg_views[v].axis;
    svg_map_t map;
    map.left = SVG_MARGIN + (double)column * (layout->column_width + SVG_GAP);
    map.top = layout->row_top[row];
    map.x0 = map.left + 0.5 * layout->column_width;
    map.y0 = map.top + 0.5 * layout->row_height[row];
    map.cx = 0.5 * (graph->low[0] + graph->high[0]);
    map.cy = 0.5 * (graph->low[axis] + graph->high[axis]);
    map.scale = graph->scale;
    map.axis = axis;
    return map;
}

/* One <path> for the lines of a style in a panel (nothing when there are none). The odometry
 * chain and ground truth skip points closer than SVG_MIN_STEP to the last one drawn. */
static void svg_path(FILE *out, const plot_lines_t *lines, plot_style_t style,
                     const svg_map_t *map, double base)
{
    if (lines->count == 0) {
        return;
    }
    int chain = style == PLOT_ODOMETRY || style == PLOT_TRUTH;
    double last_x = 0.0, last_y = 0.0;
    size_t written = 0;
    fprintf(out, "<path class=\"%s\" ", svg_styles[style].name);
    svg_stroke(out, style, base);
    fputs(" d=\"", out);
    for (size_t k = 0; k < lines->count; k++) {
        double x = map->x0 + (lines->points[k][0] - map->cx) * map->scale;
        double y = map->y0 - (lines->points[k][map->axis] - map->cy) * map->scale;
        int start = lines->starts[k];
        int ends = k + 1u == lines->count || lines->starts[k + 1u];
        if (chain && !start && !ends && fabs(x - last_x) < SVG_MIN_STEP &&
            fabs(y - last_y) < SVG_MIN_STEP) {
            continue;
        }
        const char *separator = written % 12u == 11u ? "\n" : start ? "" : " ";
        fprintf(out, "%s%s%.1f %.1f", separator, start ? "M" : "", x, y);
        last_x = x;
        last_y = y;
        written++;
    }
    fputs("\"/>\n", out);
}

/* Rings around the middle of each short loop (under 4 ring radii) of a rare class, so that
 * it is seen too; a longer one shows by itself. */
static void svg_rings(FILE *out, const plot_lines_t *lines, plot_style_t style,
                      const svg_map_t *map)
{
    int open = 0;
    for (size_t k = 0; k + 1u < lines->count; k++) {
        if (!lines->starts[k] || lines->starts[k + 1u]) {
            continue;
        }
        double dx = (lines->points[k + 1u][0] - lines->points[k][0]) * map->scale;
        double dy = (lines->points[k + 1u][map->axis] - lines->points[k][map->axis]) * map->scale;
        if (dx * dx + dy * dy >= 16.0 * SVG_RING * SVG_RING) {
            continue;
        }
        if (!open) {
            fprintf(out, "<path class=\"%s-ring\" fill=\"none\" stroke=\"%s\" "
                         "stroke-width=\"1.2\" d=\"", svg_styles[style].name,
                    svg_styles[style].colour);
            open = 1;
        }
        double x = map->x0 + (0.5 * (lines->points[k][0] + lines->points[k + 1u][0]) - map->cx) *
                                 map->scale;
        double y = map->y0 - (0.5 * (lines->points[k][map->axis] +
                                     lines->points[k + 1u][map->axis]) - map->cy) * map->scale;
        fprintf(out, "M%.1f %.1fa%.0f %.0f 0 1 0 %.0f 0a%.0f %.0f 0 1 0 %.0f 0\n", x - SVG_RING,
                y, SVG_RING, SVG_RING, 2.0 * SVG_RING, SVG_RING, SVG_RING, -2.0 * SVG_RING);
    }
    if (open) {
        fputs("\"/>\n", out);
    }
}

/* A round length (1, 2 or 5 times a power of ten) no longer than `metres`. */
static double svg_round_length(double metres)
{
    double power = pow(10.0, floor(log10(metres)));
    return 5.0 * power <= metres ? 5.0 * power : 2.0 * power <= metres ? 2.0 * power : power;
}

/* A scale bar of about a fifth of the panel width under the panel of map. */
static void svg_scale_bar(FILE *out, const svg_layout_t *layout, const svg_map_t *map, size_t g)
{
    double scale = layout->graphs[g].scale;
    double length = svg_round_length(0.2 * layout->inner / scale);
    double pixels = length * scale, x = map->left + SVG_PAD;
    double y = map->top + layout->row_height[svg_row(layout, g)] + 14.0;
    char text[64];
    if (length >= 1000.0) {
        snprintf(text, sizeof text, "%g km", length / 1000.0);
    } else {
        snprintf(text, sizeof text, "%g m", length);
    }
    fprintf(out, "<path class=\"scale\" fill=\"none\" stroke=\"#000\" stroke-width=\"1.5\" "
                 "d=\"M%.1f %.1fv5h%.1fv-5\"/>\n", x, y - 5.0, pixels);
    svg_label(out, x + pixels + 6.0, y + 4.0, "#000", SVG_TEXT_SIZE, text);
}

static void svg_panel(FILE *out, const plot_figure_t *figure, const svg_layout_t *layout,
                      size_t g, size_t v)
{
    const plot_graph_t *graph = &figure->graphs[g];
    svg_map_t map = svg_mapping(layout, g, v);
    double height = layout->row_height[svg_row(layout, g)];
    if (layout->captions) {
        char caption[256];
        const char *view = layout->views > 1u ? svg_views[v].name : "";
        snprintf(caption, sizeof caption, "%s%s%s", graph->caption,
                 graph->caption[0] != '\0' && view[0] != '\0' ? ", " : "", view);
        svg_label(out, map.left, map.top - 6.0, "#333", SVG_TEXT_SIZE, caption);
    }
    fprintf(out, "<g>\n<rect class=\"frame\" x=\"%.1f\" y=\"%.1f\" width=\"%.1f\" "
                 "height=\"%.1f\" fill=\"none\" stroke=\"#d8d8d8\"/>\n",
            map.left, map.top, layout->column_width, height);
    for (int k = 0; k < PLOT_STYLE_COUNT; k++) {
        plot_style_t style = svg_order[k];
        svg_path(out, &graph->lines[style], style, &map, layout->graphs[g].line_width);
    }
    svg_rings(out, &graph->lines[PLOT_TRUE_REJECTED], PLOT_TRUE_REJECTED, &map);
    svg_rings(out, &graph->lines[PLOT_MISSED], PLOT_MISSED, &map);
    fputs("</g>\n", out);
    if (v == 0) {
        svg_scale_bar(out, layout, &map, g);
    }
}

int plot_write_svg(const plot_figure_t *figure, FILE *out)
{
    svg_layout_t layout;
    svg_layout(figure, &layout);
    double height = ceil(layout.height);
    fprintf(out, "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" "
                 "viewBox=\"0 0 %.0f %.0f\" font-family=\"sans-serif\">\n",
            figure->width, height, figure->width, height);
    fputs("<title>", out);
    svg_text(out, figure->title);
    fputs("</title>\n<rect width=\"100%\" height=\"100%\" fill=\"#fff\"/>\n", out);
    svg_label(out, SVG_MARGIN, SVG_MARGIN + SVG_TITLE_SIZE - 4.0, "#000", SVG_TITLE_SIZE,
              figure->title);
    svg_label(out, SVG_MARGIN, SVG_MARGIN + SVG_TITLE_SIZE + 8.0 + SVG_TEXT_SIZE - 2.0, "#555",
              SVG_TEXT_SIZE, figure->subtitle);
    for (size_t g = 0; g < figure->graph_count; g++) {
        for (size_t v = 0; v < layout.views; v++) {
            svg_panel(out, figure, &layout, g, v);
        }
    }
    svg_legend(out, figure, layout.legend_top);
    fputs("</svg>\n", out);
    return ferror(out) ? -1 : 0;
}
