/*
 * fuzz_util.h: what every harness checks after a call that must either
 * succeed or fail cleanly.  A broken property aborts (libFuzzer then saves
 * the input as a crash); nothing here is used outside the harnesses.
 */
#ifndef DTX_FUZZ_UTIL_H
#define DTX_FUZZ_UTIL_H

#include "meshfile.h"
#include "meshfile_util.h"
#include "status.h"

#include <math.h>
#include <stdint.h>

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Aborts with a message: the input broke a documented property. */
#define FUZZ_ASSERT(cond)                                                                 \
    do {                                                                                  \
        if (!(cond)) {                                                                    \
            fprintf(stderr, "%s:%d: property violated: %s\n", __FILE__, __LINE__, #cond); \
            abort();                                                                      \
        }                                                                                 \
    } while (0)

/* A failed call's error: the code equals the status, is one of the
 * allowed ones (a 0-terminated list), and the message is a terminated,
 * non-empty sentence that starts with `name`. */
static inline void fuzz_check_error(dtx_status st, const dtx_error *err, const char *name,
                                    const dtx_status *allowed)
{
    int ok = 0;
    FUZZ_ASSERT(st != DTX_OK);
    FUZZ_ASSERT(err->code == st);
    for (; *allowed != DTX_OK; allowed++)
        ok |= *allowed == st;
    if (!ok)
        fprintf(stderr, "unexpected status %s: %s\n", dtx_status_name(st), err->msg);
    FUZZ_ASSERT(ok);
    FUZZ_ASSERT(memchr(err->msg, '\0', sizeof err->msg) != NULL);
    if (strncmp(err->msg, name, strlen(name)) != 0)
        fprintf(stderr, "message does not start with '%s': %s\n", name, err->msg);
    FUZZ_ASSERT(strncmp(err->msg, name, strlen(name)) == 0);
    FUZZ_ASSERT(strlen(err->msg) > strlen(name) + 2);
}

/* A warning callback that checks each warning names the file. */
static inline void fuzz_warn(void *ctx, const char *msg)
{
    const char *name = ctx;
    FUZZ_ASSERT(msg != NULL);
    FUZZ_ASSERT(strncmp(msg, name, strlen(name)) == 0);
}

/* Runs one mesh parser on the input and checks the result: on success a
 * non-empty mesh with every index in range and every coordinate finite; on
 * failure a clean error (fuzz_check_error) and an empty *out. */
static inline int fuzz_mesh_parser(dtx_mesh_parse_fn parse, const char *name, const uint8_t *data,
                                   size_t size)
{
    static const dtx_status allowed[] = {DTX_EPARSE, DTX_ERANGE, DTX_ENONFINITE, DTX_ENOMEM,
                                         DTX_OK};
    dtx_warner w = {fuzz_warn, (void *)name};
    dtx_mesh m;
    dtx_error err;
    dtx_status st;
    memset(&m, 0x5a, sizeof m); /* the parser must overwrite it */
    memset(&err, 0, sizeof err);
    st = parse(name, (const char *)data, size, &m, &w, &err);
    if (st != DTX_OK) {
        fuzz_check_error(st, &err, name, allowed);
        FUZZ_ASSERT(m.nv == 0 && m.nf == 0 && m.V == NULL && m.F == NULL);
        return 0;
    }
    FUZZ_ASSERT(m.nv > 0 && m.nf > 0 && m.V != NULL && m.F != NULL);
    for (int64_t i = 0; i < 3 * (int64_t)m.nv; i++)
        FUZZ_ASSERT(isfinite(m.V[i]));
    for (int64_t i = 0; i < 3 * (int64_t)m.nf; i++)
        FUZZ_ASSERT(m.F[i] >= 0 && m.F[i] < m.nv);
    /* What the pipeline does next with a mesh that was read. */
    (void)dtx_mesh_validate(&m, name, &err);
    dtx_mesh_free(&m);
    return 0;
}

#endif /* DTX_FUZZ_UTIL_H */
