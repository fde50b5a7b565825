/*
 * options.h: the table of every `dtx` command and its options, from which
 * `dtx help`, `dtx help COMMAND`, `dtx COMMAND --help`, each command's usage
 * text and the check of a command line's options all come.
 *
 * A command line is checked against its command's table before the command
 * parses it: an option the table does not list is a usage error naming the
 * command ("dtx diff: unknown option '--tolerance'") followed by that
 * command's usage only.  So an option a command parses but its table forgets
 * can never be used, and the help lists exactly what works (tests/cli/
 * test_help.sh also checks every option literal of the sources against the
 * help).  Options are "--name VALUE" or flags; "--" ends the options.
 *
 * Not thread-safe concerns: everything here is read-only static data and
 * pure functions over argv.
 */
#ifndef DTX_CLI_OPTIONS_H
#define DTX_CLI_OPTIONS_H

#include <stddef.h>
#include <stdio.h>

typedef struct {
    const char *name;    /* "--tol", "-o" */
    const char *metavar; /* "REL": the option takes a value; NULL: a flag */
    const char *help;    /* one line: what it does, its default */
} dtx_cli_opt;

typedef struct {
    const char *name;        /* "run", "import mesh" */
    const char *summary;     /* one line for `dtx help` */
    const char *synopsis;    /* usage lines without the leading "usage: " */
    const char *description; /* a few lines, or NULL */
    const dtx_cli_opt *opts; /* ended by {NULL} */
    const char *examples;    /* command lines, one per line */
    int words;               /* words of the name: 1, or 2 for "import mesh" */
} dtx_cli_cmd;

/* The command named by argv[1] (and argv[2] for "import ..."), or NULL. */
const dtx_cli_cmd *dtx_cli_find(int argc, char **argv);

/* The command of that name ("export", "import mesh", or "import" for the
 * first import command), or NULL. */
const dtx_cli_cmd *dtx_cli_find_name(const char *name);

/* Every command, NULL-terminated, in the order `dtx help` lists them. */
const dtx_cli_cmd *const *dtx_cli_commands(void);

/* `dtx help`: the commands with their one-line summaries. */
void dtx_cli_print_overview(FILE *fp);

/* `dtx help COMMAND`: synopsis, description, every option, examples. */
void dtx_cli_print_help(FILE *fp, const dtx_cli_cmd *c);

/* "usage: ..." of one command and a pointer to its help. */
void dtx_cli_print_usage(FILE *fp, const dtx_cli_cmd *c);

/* Checks argv[c->words + 1 ..] against the table.  Returns 1 when "--help"
 * or "-h" stands where an option may (not as an option's value); 0 when
 * every option is known and every valued option has its value; -1 with a
 * message in msg (at most n bytes) otherwise. */
int dtx_cli_check(const dtx_cli_cmd *c, int argc, char **argv, char *msg, size_t n);

#endif /* DTX_CLI_OPTIONS_H */
