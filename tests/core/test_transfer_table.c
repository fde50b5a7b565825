/* test_transfer_table.c: the method tables (core/transfer.h) are found by
 * kind and by name, and say consistent things about what each method
 * reads and reports, since the driver prepares its inputs from them. */
#include "check.h"
#include "transfer.h"

#include <string.h>

/* Every kind has its table, tagged with that kind, found again by name. */
static void lookup(void)
{
    for (int k = 0; k < DTX_TRANSFER_KINDS; k++) {
        const dtx_transfer_method *m = dtx_transfer_method_of((dtx_transfer_kind)k);
        CHECK(m != NULL);
        if (!m)
            continue;
        CHECK_EQ_INT((int)m->kind, k);
        CHECK(dtx_transfer_method_named(m->name) == m);
    }
    CHECK(dtx_transfer_method_of(DTX_TRANSFER_KINDS) == NULL);
    CHECK(dtx_transfer_method_named("cloth") == NULL);
    CHECK(dtx_transfer_method_named("") == NULL);
    CHECK(dtx_transfer_method_named(NULL) == NULL);
}

/* What the driver relies on: a solver name exactly for the iterative
 * methods, inverted counts and final gradient norms only from them, every method reads a
 * correspondence's pairs, a proxy or key points, and a method that reads
 * pairs for a target of several components builds on the correspondence
 * that pairs such a target. */
static void consistent(void)
{
    for (int k = 0; k < DTX_TRANSFER_KINDS; k++) {
        const dtx_transfer_method *m = dtx_transfer_method_of((dtx_transfer_kind)k);
        CHECK_EQ_INT(m->solver_name != NULL, m->iterative != 0);
        CHECK(!m->counts_inverted || m->iterative);
        CHECK(!m->reports_grad_norm || m->iterative);
        CHECK(m->uses_pairs || m->uses_proxy || m->uses_keypoints);
        CHECK(!(m->uses_pairs && m->multi_component_target) ||
              m->correspondence == DTX_TRANSFER_CORR_MULTICOMPONENT);
        CHECK(m->solve_group >= 1);
    }
}

/* The four methods as the README and the job schema describe them. */
static void members(void)
{
    CHECK(dtx_method_sp04.uses_pairs && !dtx_method_sp04.multi_component_target);
    CHECK(dtx_method_multicomponent.uses_pairs &&
          dtx_method_multicomponent.multi_component_target &&
          strcmp(dtx_method_multicomponent.solver_name, "Gauss-Newton") == 0);
    {
        /* A run names the solver its parameters choose. */
        dtx_transfer_params prm;
        dtx_transfer_params_default(&prm, DTX_TRANSFER_MULTICOMPONENT);
        CHECK(strcmp(dtx_transfer_solver_name(&dtx_method_multicomponent, &prm), "Gauss-Newton") ==
              0);
        prm.u.mc.solver = DTX_MC_SOLVER_NEWTON;
        CHECK(strcmp(dtx_transfer_solver_name(&dtx_method_multicomponent, &prm), "Newton") == 0);
        dtx_transfer_params_default(&prm, DTX_TRANSFER_SPRINGS);
        CHECK(strcmp(dtx_transfer_solver_name(&dtx_method_springs, &prm), "Newton") == 0);
    }
    /* Only springs writes frame_grad_norm (README: Springs). */
    CHECK(dtx_method_springs.reports_grad_norm && !dtx_method_multicomponent.reports_grad_norm &&
          !dtx_method_sp04.reports_grad_norm && !dtx_method_biharmonic.reports_grad_norm);
    CHECK(dtx_method_springs.uses_proxy && !dtx_method_springs.uses_pairs &&
          dtx_method_springs.counts_inverted &&
          strcmp(dtx_method_springs.solver_name, "Newton") == 0);
    CHECK(dtx_method_biharmonic.uses_keypoints && !dtx_method_biharmonic.uses_pairs &&
          dtx_method_biharmonic.multi_component_target &&
          dtx_method_biharmonic.correspondence == DTX_TRANSFER_CORR_SP04);
}

int main(void)
{
    lookup();
    consistent();
    members();
    return check_report();
}
