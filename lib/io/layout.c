/* pgem I/O layout: information-matrix order of each format and identity poses. */
#include <string.h>

#include "io_internal.h"

/* TORO 2D writes Ixx Ixy Iyy Itt Ixt Iyt; as (row, col) of the 3x3 matrix: */
static const unsigned char io_toro_cells[6][2] = {{0, 0}, {0, 1}, {1, 1}, {2, 2}, {0, 2}, {1, 2}};

size_t io_info_values(int dimension)
{
    size_t n = (size_t)PGEM_TANGENT_SIZE(dimension);
    return n * (n + 1) / 2;
}

/* g2o: the upper triangle row by row: (0,0) (0,1) .. (0,n-1) (1,1) .. (n-1,n-1). */
static void io_upper_row_major_cell(size_t n, size_t k, size_t *row, size_t *col)
{
    size_t r = 0;
    while (k >= n - r) {
        k -= n - r;
        r++;
    }
    *row = r;
    *col = r + k;
}

void io_info_cell(pgem_format_t format, int dimension, size_t k, size_t *row, size_t *col)
{
    if (format == PGEM_FORMAT_TORO && dimension == 2) {
        *row = io_toro_cells[k][0];
        *col = io_toro_cells[k][1];
        return;
    }
    io_upper_row_major_cell((size_t)PGEM_TANGENT_SIZE(dimension), k, row, col);
}

void io_identity_pose(int dimension, double *pose)
{
    memset(pose, 0, sizeof(double) * PGEM_POSE_SIZE_MAX);
    if (dimension == 3) {
        pose[6] = 1.0;
    }
}
