/*
 * transfer.c: the one place that maps a transfer kind to its method table
 * (transfer.h), the parameters' defaults, and the adapters' scratch.
 */
#include "transfer.h"

#include <stdlib.h>
#include <string.h>

const dtx_transfer_method *dtx_transfer_method_of(dtx_transfer_kind kind)
{
    static const dtx_transfer_method *const methods[DTX_TRANSFER_KINDS] = {
        [DTX_TRANSFER_SP04] = &dtx_method_sp04,
        [DTX_TRANSFER_MULTICOMPONENT] = &dtx_method_multicomponent,
        [DTX_TRANSFER_SPRINGS] = &dtx_method_springs,
        [DTX_TRANSFER_BIHARMONIC] = &dtx_method_biharmonic,
    };
    return (unsigned)kind < DTX_TRANSFER_KINDS ? methods[kind] : NULL;
}

const dtx_transfer_method *dtx_transfer_method_named(const char *name)
{
    for (int k = 0; name && k < DTX_TRANSFER_KINDS; k++) {
        const dtx_transfer_method *m = dtx_transfer_method_of((dtx_transfer_kind)k);
        if (strcmp(m->name, name) == 0)
            return m;
    }
    return NULL;
}

const char *dtx_transfer_solver_name(const dtx_transfer_method *m, const dtx_transfer_params *prm)
{
    return m->solver_of && prm ? m->solver_of(prm) : m->solver_name;
}

void dtx_transfer_params_default(dtx_transfer_params *p, dtx_transfer_kind kind)
{
    memset(p, 0, sizeof *p);
    p->kind = kind;
    if (kind == DTX_TRANSFER_MULTICOMPONENT)
        dtx_mc_params_default(&p->u.mc);
    else if (kind == DTX_TRANSFER_SPRINGS)
        dtx_springs_params_default(&p->u.springs);
    else if (kind == DTX_TRANSFER_BIHARMONIC)
        dtx_bh_params_default(&p->u.bh);
}

dtx_status dtx_transfer_scratch(void **buf, int64_t *cap, int64_t n, size_t size, dtx_error *err)
{
    void *p;
    if (n <= *cap)
        return DTX_OK;
    p = dtx_alloc((size_t)n, size, 0);
    if (!p)
        return dtx_seterr(err, DTX_ENOMEM, "out of memory");
    free(*buf);
    *buf = p;
    *cap = n;
    return DTX_OK;
}
