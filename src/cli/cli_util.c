/*
 * cli_util.c: messages and option lookup shared by the `dtx` commands.
 */
#define _XOPEN_SOURCE 700 /* nftw */
#include "cli_util.h"
#include "options.h"

#include "h5layout.h"

#include <dirent.h>
#include <errno.h>
#include <ftw.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int dtx_cli_quiet_rank(void)
{
    const char *r = getenv("OMPI_COMM_WORLD_RANK");
    return r && strcmp(r, "0") != 0;
}

int dtx_cli_usage(const dtx_cli_cmd *c, const char *msg)
{
    if (msg)
        fprintf(stderr, "dtx: %s\n", msg);
    if (c)
        dtx_cli_print_usage(stderr, c);
    else
        dtx_cli_print_overview(stderr);
    return 2;
}

int dtx_cli_usage_rank0(const dtx_cli_cmd *c, const char *msg)
{
    return dtx_cli_quiet_rank() ? 2 : dtx_cli_usage(c, msg);
}

int dtx_cli_fail(const dtx_error *err)
{
    fprintf(stderr, "dtx: error: %s\n", err->msg);
    return 1;
}

void dtx_cli_print_warning(void *ctx, const char *msg)
{
    (void)ctx;
    fprintf(stderr, "dtx: warning: %s\n", msg);
}

/* The isolated singleton's own session directory (empty once MPI_Finalize
 * has cleaned it), removed at exit; "" when there is none. */
static char session_base[4096];

static void remove_session_base(void)
{
    if (session_base[0])
        rmdir(session_base);
    session_base[0] = '\0';
}

static int remove_entry(const char *path, const struct stat *st, int flag, struct FTW *ftw)
{
    (void)st, (void)flag, (void)ftw;
    remove(path);
    return 0;
}

/* Removes the session directories under tmp that singletons of this host
 * left when they were killed (kill -9 runs no exit handler): those named
 * dtx-mpi-HOST-PID-* with this HOST, owned by this user, whose PID is no
 * longer running.  A directory of another host (a shared TMPDIR) or of a
 * live process is left alone. */
static void sweep_stale_sessions(const char *tmp, const char *host)
{
    char prefix[128], path[4096];
    struct dirent *e;
    DIR *d = opendir(tmp);
    size_t n = (size_t)snprintf(prefix, sizeof prefix, "dtx-mpi-%s-", host);
    if (!d)
        return;
    while ((e = readdir(d)) != NULL) {
        struct stat st;
        char *end;
        long pid;
        if (strncmp(e->d_name, prefix, n) != 0)
            continue;
        errno = 0;
        pid = strtol(e->d_name + n, &end, 10);
        if (errno || pid <= 0 || *end != '-' || (pid_t)pid == getpid())
            continue;
        if (kill((pid_t)pid, 0) == 0 || errno != ESRCH)
            continue;
        if (snprintf(path, sizeof path, "%s/%s", tmp, e->d_name) >= (int)sizeof path)
            continue;
        if (lstat(path, &st) != 0 || !S_ISDIR(st.st_mode) || st.st_uid != getuid())
            continue;
        nftw(path, remove_entry, 16, FTW_DEPTH | FTW_PHYS);
    }
    closedir(d);
}

/* This host's name as it goes into a file name: letters, digits, '.' and
 * '-' only, at most 63 characters. */
static void host_tag(char *out, size_t n)
{
    char h[256] = "";
    size_t k = 0;
    gethostname(h, sizeof h - 1);
    for (const char *c = h; *c && k + 1 < n && k < 63; c++)
        if ((*c >= 'a' && *c <= 'z') || (*c >= 'A' && *c <= 'Z') || (*c >= '0' && *c <= '9') ||
            *c == '.' || *c == '-')
            out[k++] = *c;
    if (k == 0 && n > 4)
        k = (size_t)snprintf(out, n, "host");
    out[k] = '\0';
}

void dtx_cli_mpi_init(int *argc, char ***argv)
{
    int provided;
    if (!getenv("OMPI_COMM_WORLD_SIZE") && !getenv("PMIX_RANK") && !getenv("PMI_RANK") &&
        !getenv("OMPI_MCA_ess_singleton_isolated")) {
        setenv("OMPI_MCA_ess_singleton_isolated", "1", 1);
        /* A singleton talks to no other process: OpenMPI's ob1 messaging
         * layer starts at once, where the default selection first opens
         * UCX and libfabric (0.32 s -> 0.11 s per start on this machine). */
        if (!getenv("OMPI_MCA_pml"))
            setenv("OMPI_MCA_pml", "ob1", 1);
        /* Isolated singletons all get job family 0: without a directory
         * of their own, concurrent ones (make -j) would share OpenMPI's
         * session directory, and the first to finish would delete the
         * files (MPI-IO's shared-file-pointer segments) of the others. */
        if (!getenv("OMPI_MCA_orte_tmpdir_base")) {
            const char *tmp = getenv("TMPDIR");
            char host[64];
            tmp = tmp && *tmp ? tmp : "/tmp";
            host_tag(host, sizeof host);
            sweep_stale_sessions(tmp, host);
            snprintf(session_base, sizeof session_base, "%s/dtx-mpi-%s-%ld-XXXXXX", tmp, host,
                     (long)getpid());
            if (mkdtemp(session_base)) {
                setenv("OMPI_MCA_orte_tmpdir_base", session_base, 1);
                atexit(remove_session_base);
            } else {
                session_base[0] = '\0';
            }
        }
    }
    MPI_Init_thread(argc, argv, MPI_THREAD_FUNNELED, &provided);
}

int dtx_cli_mpi_finish(dtx_status st)
{
    int stuck = H5Fget_obj_count(H5F_OBJ_ALL, H5F_OBJ_ALL) > 0;
    MPI_Finalize();
    if (stuck) {
        fflush(NULL);
        remove_session_base();
        _exit(st == DTX_OK ? 0 : 1);
    }
    return st == DTX_OK ? 0 : 1;
}

const char *dtx_cli_opt_value(int argc, char **argv, const char *name)
{
    for (int i = 0; i < argc - 1; i++)
        if (strcmp(argv[i], name) == 0)
            return argv[i + 1];
    return NULL;
}

int dtx_cli_take_slot(const char *cmd, const dtx_cli_slot *slots, size_t nslots, int reject_empty,
                      void *args, int argc, char **argv, int *i, char *buf, size_t n)
{
    const char *s = argv[*i], **slot;
    size_t v;
    for (v = 0; v < nslots && strcmp(s, slots[v].name) != 0; v++)
        ;
    if (v == nslots)
        return 0;
    slot = (const char **)((char *)args + slots[v].off);
    if (*i + 1 >= argc || (reject_empty && argv[*i + 1][0] == '\0')) {
        snprintf(buf, n, "%s: %s needs a value", cmd, s);
        return -1;
    }
    if (*slot) {
        snprintf(buf, n, "%s: %s given twice", cmd, s);
        return -1;
    }
    *slot = argv[++*i];
    return 1;
}

/* The options of import and run that take a value (and diff's --tol, from
 * when main.c parsed diff too). */
static int is_flag_with_value(const char *a)
{
    static const char *const names[] = {
        "-o",        "--name", "--mesh",     "--dtype", "--index-base", "--source", "--target",
        "--summary", "--tol",  "--compress", "--fps",   "--glob",       "--exclude"};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++)
        if (strcmp(a, names[i]) == 0)
            return 1;
    return 0;
}

/* Whether option a of command c takes a value: its table (options.h) says
 * so when it lists a; the list above otherwise. */
static int takes_value(const dtx_cli_cmd *c, const char *a)
{
    for (const dtx_cli_opt *o = c ? c->opts : NULL; o && o->name; o++)
        if (strcmp(o->name, a) == 0)
            return o->metavar != NULL;
    return is_flag_with_value(a);
}

int dtx_cli_positionals(int argc, char **argv, int from, char **out, int cap)
{
    const dtx_cli_cmd *c = dtx_cli_find(argc, argv);
    int n = 0;
    for (int i = from; i < argc; i++) {
        if (takes_value(c, argv[i])) {
            i++;
            continue;
        }
        if (argv[i][0] == '-' && argv[i][1] == '-')
            continue;
        if (n < cap)
            out[n] = argv[i];
        n++;
    }
    return n;
}
