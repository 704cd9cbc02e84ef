/* pgem: the command-line tool. Dispatches to one verb per file. */
#include <stdio.h>
#include <string.h>

#include "cli.h"

static void pgem_usage(FILE *out)
{
    fprintf(out,
            "usage: pgem <command> [<args>]\n"
            "\n"
            "Robust pose-graph optimisation (EM loop-closure weighting) on a fixed-memory core.\n"
            "\n"
            "commands:\n"
            "   optimize   optimize a g2o or TORO pose graph\n"
            "   corrupt    add false loop closures (random, local, grouped) to a graph\n"
            "   eval       score a result against a reference (ATE, RPE, loop rejection)\n"
            "   simulate   generate a graph with ground truth (2D Manhattan walk, 3D sphere or grid)\n"
            "   plot       draw a graph as SVG, loop closures coloured accepted/rejected\n"
            "   stats      check a graph before optimizing (counts, connectivity, defects)\n"
            "\n"
            "'pgem <command> --help' describes a command. Exit codes: 0 success, 1 the solve\n"
            "failed or the input was rejected, 2 bad command line, 3 a file could not be read or\n"
            "written.\n");
}

int main(int argc, char **argv)
{
    if (argc < 2 || strcmp(argv[1], "--help") == 0 || strcmp(argv[1], "-h") == 0) {
        pgem_usage(argc < 2 ? stderr : stdout);
        return argc < 2 ? PGEM_EXIT_USAGE : PGEM_EXIT_OK;
    }
    if (strcmp(argv[1], "--version") == 0) {
        printf("pgem %d.%d.%d\n", PGEM_VERSION_MAJOR, PGEM_VERSION_MINOR, PGEM_VERSION_PATCH);
        return PGEM_EXIT_OK;
    }
    if (strcmp(argv[1], "optimize") == 0) {
        return pgem_cmd_optimize(argc - 1, argv + 1);
    }
    if (strcmp(argv[1], "corrupt") == 0) {
        return pgem_cmd_corrupt(argc - 1, argv + 1);
    }
    if (strcmp(argv[1], "eval") == 0) {
        return pgem_cmd_eval(argc - 1, argv + 1);
    }
    if (strcmp(argv[1], "simulate") == 0) {
        return pgem_cmd_simulate(argc - 1, argv + 1);
    }
    if (strcmp(argv[1], "plot") == 0) {
        return pgem_cmd_plot(argc - 1, argv + 1);
    }
    if (strcmp(argv[1], "stats") == 0) {
        return pgem_cmd_stats(argc - 1, argv + 1);
    }
    fprintf(stderr, "pgem: '%s' is not a pgem command. See 'pgem --help'.\n", argv[1]);
    return PGEM_EXIT_USAGE;
}
