/*
 * path_guard.c: dtx never writes to, renames over or deletes its inputs
 * (see path_guard.h).
 */
#define _GNU_SOURCE
#include "path_guard.h"

#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* The canonical name of path (malloc'ed): realpath() when the path exists,
 * else realpath() of its directory plus its last component; NULL when the
 * directory does not exist either (or on a lack of memory). */
static char *canonical(const char *path)
{
    char *r = realpath(path, NULL), *dir, *slash, *dreal, *out;
    const char *base;
    size_t n;
    if (r)
        return r;
    dir = strdup(path);
    if (!dir)
        return NULL;
    /* Trailing slashes belong to the last component's spelling only. */
    n = strlen(dir);
    while (n > 1 && dir[n - 1] == '/')
        dir[--n] = '\0';
    slash = strrchr(dir, '/');
    if (slash) {
        *slash = '\0';
        base = slash + 1;
        dreal = realpath(dir[0] ? dir : "/", NULL);
    } else {
        base = dir;
        dreal = realpath(".", NULL);
    }
    out = NULL;
    if (dreal && strcmp(base, ".") != 0 && strcmp(base, "..") != 0) {
        out = malloc(strlen(dreal) + strlen(base) + 2);
        if (out)
            sprintf(out, "%s%s%s", dreal, strcmp(dreal, "/") == 0 ? "" : "/", base);
    }
    free(dreal);
    free(dir);
    return out;
}

void dtx_path_guard_init(dtx_path_guard *g) { memset(g, 0, sizeof *g); }

dtx_status dtx_path_guard_add(dtx_path_guard *g, const char *path, const char *role,
                              dtx_error *err)
{
    dtx_path_guard_entry *e;
    struct stat sb;
    if (!path)
        return DTX_OK;
    if (g->n == g->cap) {
        int cap = g->cap ? 2 * g->cap : 8;
        dtx_path_guard_entry *v = realloc(g->in, (size_t)cap * sizeof *v);
        if (!v)
            return dtx_seterr(err, DTX_ENOMEM, "out of memory");
        g->in = v;
        g->cap = cap;
    }
    e = &g->in[g->n];
    memset(e, 0, sizeof *e);
    e->path = strdup(path);
    if (!e->path)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    e->canon = canonical(path);
    e->role = strdup(role ? role : "an input");
    if (!e->role) {
        free(e->path);
        free(e->canon);
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    }
    if (stat(path, &sb) == 0) {
        e->exists = 1;
        e->dev = sb.st_dev;
        e->ino = sb.st_ino;
    }
    g->n++;
    return DTX_OK;
}

int dtx_path_guard_same(const dtx_path_guard *g, int i, const char *path)
{
    const dtx_path_guard_entry *e = &g->in[i];
    struct stat sb;
    char *c;
    int same;
    if (e->exists && stat(path, &sb) == 0 && sb.st_dev == e->dev && sb.st_ino == e->ino)
        return 1;
    if (strcmp(path, e->path) == 0)
        return 1;
    c = canonical(path);
    same = c && e->canon && strcmp(c, e->canon) == 0;
    free(c);
    return same;
}

dtx_status dtx_path_guard_check(const dtx_path_guard *g, const char *path, const char *use,
                                dtx_error *err)
{
    for (int i = 0; i < g->n; i++)
        if (dtx_path_guard_same(g, i, path))
            return dtx_seterr(err, DTX_EINVAL,
                              "%s (%s) is also an input (%s %s): dtx does not write over, "
                              "rename over or delete its inputs; choose another output name",
                              path, use ? use : "an output", g->in[i].role, g->in[i].path);
    return DTX_OK;
}

dtx_status dtx_path_guard_check_pair(const char *input, const char *role, const char *path,
                                     const char *use, dtx_error *err)
{
    dtx_path_guard g;
    dtx_status st;
    dtx_path_guard_init(&g);
    st = dtx_path_guard_add(&g, input, role, err);
    if (st == DTX_OK)
        st = dtx_path_guard_check(&g, path, use, err);
    dtx_path_guard_free(&g);
    return st;
}

dtx_status dtx_output_path_check(const char *path, const char *use, dtx_error *err)
{
    struct stat sb;
    const char *what;
    if (stat(path, &sb) != 0 || S_ISREG(sb.st_mode))
        return DTX_OK;
    what = S_ISDIR(sb.st_mode)    ? "a directory"
           : S_ISCHR(sb.st_mode) || S_ISBLK(sb.st_mode) ? "a device"
           : S_ISFIFO(sb.st_mode) ? "a FIFO"
           : S_ISSOCK(sb.st_mode) ? "a socket"
                                  : "not a regular file";
    return dtx_seterr(err, DTX_EINVAL,
                      "%s (%s) is %s: give a file name for it (nothing was read or written)",
                      path, use ? use : "an output", what);
}

void dtx_path_guard_free(dtx_path_guard *g)
{
    for (int i = 0; g->in && i < g->n; i++) {
        free(g->in[i].path);
        free(g->in[i].canon);
        free(g->in[i].role);
    }
    free(g->in);
    memset(g, 0, sizeof *g);
}
