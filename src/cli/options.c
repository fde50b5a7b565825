/*
 * options.c: looking commands up in the table of commands.c, printing their
 * help and usage, and checking a command line's options against the table.
 */
#include "options.h"

#include <string.h>

const dtx_cli_cmd *dtx_cli_find_name(const char *name)
{
    const dtx_cli_cmd *const *all = dtx_cli_commands();
    size_t n = strlen(name);
    for (int i = 0; all[i]; i++)
        if (strcmp(all[i]->name, name) == 0)
            return all[i];
    /* "import" alone: the first of the import commands. */
    for (int i = 0; all[i]; i++)
        if (strncmp(all[i]->name, name, n) == 0 && all[i]->name[n] == ' ')
            return all[i];
    return NULL;
}

/* 1 when name is "a b". */
static int is_two_words(const char *name, const char *a, const char *b)
{
    size_t n = strlen(a);
    return strncmp(name, a, n) == 0 && name[n] == ' ' && strcmp(name + n + 1, b) == 0;
}

const dtx_cli_cmd *dtx_cli_find(int argc, char **argv)
{
    const dtx_cli_cmd *const *all = dtx_cli_commands();
    if (argc < 2)
        return NULL;
    for (int i = 0; argc >= 3 && all[i]; i++)
        if (all[i]->words == 2 && is_two_words(all[i]->name, argv[1], argv[2]))
            return all[i];
    for (int i = 0; all[i]; i++)
        if (all[i]->words == 1 && strcmp(all[i]->name, argv[1]) == 0)
            return all[i];
    return NULL;
}

void dtx_cli_print_overview(FILE *fp)
{
    const dtx_cli_cmd *const *all = dtx_cli_commands();
    fputs("dtx: deformation transfer of mesh animations at dataset scale.\n\n"
          "usage: dtx COMMAND [ARGS...]        (dtx run and dtx keypoints also under mpirun)\n\n"
          "commands:\n",
          fp);
    for (int i = 0; all[i]; i++)
        fprintf(fp, "  %-17s %s\n", all[i]->name, all[i]->summary);
    fputs("\n`dtx help COMMAND` or `dtx COMMAND --help` describes a command and every option.\n"
          "`dtx --version` prints the version.  Exit status: 0 success, 1 error, 2 usage error.\n",
          fp);
}

/* Prints text with every line indented by `indent` spaces. */
static void indented(FILE *fp, const char *text, int indent)
{
    const char *p = text;
    while (*p) {
        const char *e = strchr(p, '\n');
        size_t n = e ? (size_t)(e - p) : strlen(p);
        if (n)
            fprintf(fp, "%*s%.*s\n", indent, "", (int)n, p);
        else
            fputc('\n', fp);
        p += n + (e != NULL);
    }
}

void dtx_cli_print_help(FILE *fp, const dtx_cli_cmd *c)
{
    fprintf(fp, "dtx %s: %s\n\nusage:\n", c->name, c->summary);
    indented(fp, c->synopsis, 2);
    if (c->description) {
        fputc('\n', fp);
        indented(fp, c->description, 0);
    }
    fputs("\noptions:\n", fp);
    for (const dtx_cli_opt *o = c->opts; o->name; o++) {
        char head[64];
        snprintf(head, sizeof head, "%s%s%s", o->name, o->metavar ? " " : "",
                 o->metavar ? o->metavar : "");
        if (strlen(head) <= 22)
            fprintf(fp, "  %-22s %s\n", head, o->help);
        else
            fprintf(fp, "  %s\n  %-22s %s\n", head, "", o->help);
    }
    fprintf(fp, "  %-22s %s\n", "-h, --help", "print this help and exit");
    if (c->examples) {
        fputs("\nexamples:\n", fp);
        indented(fp, c->examples, 2);
    }
}

void dtx_cli_print_usage(FILE *fp, const dtx_cli_cmd *c)
{
    fputs("usage:\n", fp);
    indented(fp, c->synopsis, 2);
    fprintf(fp, "(`dtx help %s` describes every option)\n", c->name);
}

static const dtx_cli_opt *lookup(const dtx_cli_cmd *c, const char *name)
{
    for (const dtx_cli_opt *o = c->opts; o->name; o++)
        if (strcmp(o->name, name) == 0)
            return o;
    return NULL;
}

/* "-" alone (standard input or output) and negative numbers are arguments,
 * not options. */
static int looks_like_option(const char *a)
{
    if (a[0] != '-' || a[1] == '\0')
        return 0;
    if ((a[1] >= '0' && a[1] <= '9') || a[1] == '.')
        return 0;
    return 1;
}

int dtx_cli_check(const dtx_cli_cmd *c, int argc, char **argv, char *msg, size_t n)
{
    for (int i = 1 + c->words; i < argc; i++) {
        const char *a = argv[i];
        const dtx_cli_opt *o;
        if (strcmp(a, "--") == 0)
            break;
        if (!looks_like_option(a))
            continue;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0)
            return 1;
        if (!(o = lookup(c, a))) {
            snprintf(msg, n, "dtx: %s: unknown option %s", c->name, a);
            return -1;
        }
        if (o->metavar) {
            if (i + 1 >= argc) {
                snprintf(msg, n, "dtx: %s: %s needs a value (%s %s)", c->name, a, a, o->metavar);
                return -1;
            }
            i++;
        }
    }
    return 0;
}
