/* The one argument loop of every tool (pgem's commands and the LCM tools): help, a tool's
 * common options, its flags, its options with a value and its positional arguments. */
#include <stdio.h>
#include <string.h>

#include "cli.h"

static int pgem_cli_takes_value(const pgem_cli_parser_t *parser, const char *name)
{
    for (size_t v = 0; v < parser->valued_count; ++v) {
        if (strcmp(name, parser->valued[v]) == 0) {
            return 1;
        }
    }
    return 0;
}

/* What argv[*k] is, taken (1), a usage error already printed (PGEM_EXIT_USAGE) or not one of
 * the tool's (0). */
static int pgem_cli_take(const pgem_cli_parser_t *parser, void *args, int argc, char **argv,
                         int *k)
{
    const char *arg = argv[*k];
    if (parser->flag != NULL && parser->flag(args, arg)) {
        return 1;
    }
    if (pgem_cli_takes_value(parser, arg)) {
        const char *value = *k + 1 < argc ? argv[*k + 1] : NULL;
        if (!parser->value(args, arg, value)) {
            return PGEM_EXIT_USAGE;
        }
        *k += 1;
        return 1;
    }
    if ((arg[0] != '-' || arg[1] == '\0') && parser->positional != NULL) {
        return parser->positional(args, arg) ? 1 : PGEM_EXIT_USAGE;
    }
    return 0;
}

int pgem_cli_parse_args(const pgem_cli_parser_t *parser, void *args, int argc, char **argv)
{
    for (int k = 1; k < argc; k++) {
        const char *arg = argv[k];
        if (parser->common != NULL) {
            int common = parser->common(parser->context, argc, argv, &k);
            if (common < 0) {
                return PGEM_EXIT_USAGE;
            }
            if (common > 0) {
                continue;
            }
        }
        if (strcmp(arg, "-h") == 0 || strcmp(arg, "--help") == 0) {
            parser->help(stdout, parser->context);
            return -1;
        }
        int taken = pgem_cli_take(parser, args, argc, argv, &k);
        if (taken == PGEM_EXIT_USAGE) {
            return PGEM_EXIT_USAGE;
        }
        if (taken == 0) {
            fprintf(stderr, "%s: unknown %s '%s' (see %s --help)\n", parser->tool,
                    arg[0] == '-' ? "option" : "argument", arg, parser->tool);
            return PGEM_EXIT_USAGE;
        }
    }
    return 0;
}

int pgem_cli_one_file(const char *tool, const char *what, const char **field,
                      const char *argument)
{
    if (*field != NULL) {
        fprintf(stderr, "%s: more than one %s file ('%s')\n", tool, what, argument);
        return 0;
    }
    *field = argument;
    return 1;
}

int pgem_cli_text_value(const char *tool, const char *name, const char *value, const char *noun,
                        const char **field)
{
    if (value == NULL) {
        fprintf(stderr, "%s: %s needs %s\n", tool, name, noun);
        return 0;
    }
    *field = value;
    return 1;
}
