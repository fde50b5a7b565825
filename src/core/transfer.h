/*
 * transfer.h: the family of transfer methods behind one interface.
 *
 * Each method (sp04, multicomponent, springs, biharmonic) is a member of
 * the family: a table of function pointers (dtx_transfer_method) that its
 * own file provides, wrapping that method's plan_create / apply / free.  A
 * caller picks the table once (dtx_transfer_method_of) and then calls
 * through it without knowing which member it has: precompute a plan per
 * target, apply it to blocks of frames, free it.  The table also says which
 * inputs the method reads (its correspondence, pairs, a proxy, key points)
 * and what it reports, so that a caller prepares them by asking the table
 * instead of naming the method.  Adding a method touches its own file,
 * this header's kind, union and extern, and the lookup in transfer.c (and,
 * for a job file to name it, io's job parser); the driver too only when it
 * reads an input the driver does not prepare yet.
 *
 * Every apply reports one dtx_frame_info per frame; fields a method does
 * not have are -1, or NaN for a real number (the residual every method
 * has).
 */
#ifndef DTX_TRANSFER_H
#define DTX_TRANSFER_H

#include "dtx_core.h"
#include "springs.h"
#include "transfer_bh.h"

#include <stddef.h>
#include <stdint.h>

/* The members of the family, the tag of dtx_transfer_params. */
typedef enum {
    DTX_TRANSFER_SP04 = 0,
    DTX_TRANSFER_MULTICOMPONENT,
    DTX_TRANSFER_SPRINGS,
    DTX_TRANSFER_BIHARMONIC,
    DTX_TRANSFER_KINDS
} dtx_transfer_kind;

/* The correspondences a method can build on (dtx_core.h). */
typedef enum {
    DTX_TRANSFER_CORR_SP04 = 0,      /* dtx_sp04_correspond: a target of one connected
                                        component; pairs and the deformed source */
    DTX_TRANSFER_CORR_MULTICOMPONENT /* dtx_mc_correspond: a target of several
                                        components; pairs only */
} dtx_transfer_corr;

/* A method's own parameters, tagged by kind (sp04 has none). */
typedef struct {
    dtx_transfer_kind kind;
    union {
        dtx_mc_params mc;           /* DTX_TRANSFER_MULTICOMPONENT */
        dtx_springs_params springs; /* DTX_TRANSFER_SPRINGS */
        dtx_bh_params bh;           /* DTX_TRANSFER_BIHARMONIC */
    } u;
} dtx_transfer_params;

/* kind and that method's defaults (dtx_mc_params_default etc.). */
void dtx_transfer_params_default(dtx_transfer_params *p, dtx_transfer_kind kind);

/* What a plan is built from.  Each method reads the fields it names and
 * ignores the others (which may be NULL / 0).  Nothing is kept: a plan
 * copies what it needs. */
typedef struct {
    const dtx_mesh *src, *tgt; /* rest meshes (all methods) */
    const int32_t *pairs;      /* sp04, multicomponent: npairs x 2 (source */
    int64_t npairs;            /*   triangle, target triangle) */
    const double *proxy;       /* springs: the source deformed onto the target
                                  (nv_src x 3) when the target's connectivity
                                  differs, else NULL */
    const int32_t *src_keys;   /* biharmonic: nkeys key points on each mesh */
    const int32_t *tgt_keys;
    int32_t nkeys;
    const double *src_weights; /* biharmonic: the bounded biharmonic weights of */
    const double *tgt_weights; /*   the key points (nv x nkeys), or NULL: computed */
    int32_t ntrain;        /* biharmonic: training frames Xtrain */
    const double *Xtrain;  /*   (ntrain x nv_src x 3, NULL when 0) */
    dtx_anchor anchor;     /* sp04, multicomponent, springs; biharmonic: */
    const int32_t *pins;   /*   DTX_ANCHOR_FIXED keeps each frame's centroid */
    const double *pin_pos; /*   at the target's rest centroid */
    int32_t npins;         /* pins: npins vertices at pin_pos (npins x 3) */
} dtx_transfer_inputs;

/* One frame's figures from an apply; -1 where a method has none. */
typedef struct {
    double residual;    /* the method's residual (see its header); NaN for a
                           frame with non-finite input */
    int32_t iterations; /* solves on the finest level (iterative methods) */
    int32_t converged;  /* 1 when the stopping test was met, 0 when not */
    int32_t inverted;   /* inverted target triangles (springs) */
    double grad_norm;   /* Euclidean norm of the energy's gradient at the
                           result (springs; see its frame info); NaN where
                           a method has none or for a non-finite frame */
} dtx_frame_info;

/* One setting of a method, as a job file's method object names it: the
 * job parser reads it and the run's parameter text (provenance, resume
 * key) writes it from this description alone, so a new setting is its
 * struct field, its default, one row of its method's table, the job
 * schema (types and ranges) and the docs.  offset is within the method's
 * own parameter struct (the member of dtx_transfer_params.u). */
typedef enum {
    DTX_SETTING_DOUBLE, /* double */
    DTX_SETTING_INT,    /* int (int32_t is int on every platform dtx builds for) */
    DTX_SETTING_BOOL,   /* int, 0 or 1; JSON true / false */
    DTX_SETTING_CHOICE  /* an enum whose values are 0, 1, ...: choices[value] */
} dtx_setting_type;

typedef struct {
    const char *name;
    dtx_setting_type type;
    size_t offset;
    const char *const *choices; /* DTX_SETTING_CHOICE: NULL-terminated names */
} dtx_setting;

/* One member of the family.  plan is the method's own (opaque) plan. */
typedef struct dtx_transfer_method {
    const char *name;       /* as in a job file: "sp04", "multicomponent", ... */
    dtx_transfer_kind kind; /* the tag its parameters carry */
    int iterative;          /* 1: frame infos carry iterations and converged */
    int32_t solve_group;    /* frames per group for a caller that splits a
                               sequence (ranks, blocks, chunks): sp04's solve
                               group, so that no group is partly filled; 1 for
                               springs, whose frames are independent and
                               expensive, so that few frames still spread */

    /* What a caller prepares for plan_create (which dtx_transfer_inputs it
     * reads) and what apply reports, so that a caller asks the table
     * instead of naming methods.  A table leaves out what is 0. */

    /* The correspondence it builds on where it needs one (pairs, a proxy,
     * key points to map). */
    dtx_transfer_corr correspondence;
    /* 1: reads pairs, so every target needs the correspondence. */
    int uses_pairs;
    /* 1: reads proxy, the correspondence's deformed source, for a target
     * whose vertices and faces differ from the source's; a target with the
     * source's needs neither correspondence nor markers, and only such a
     * target takes pins (plan_create refuses pins with a proxy). */
    int uses_proxy;
    /* 1: reads src_keys, tgt_keys and Xtrain: key points that are a
     * target's markers, or that are selected on the training frames and
     * mapped through the correspondence (needed then only). */
    int uses_keypoints;
    /* 1: a target may have several connected components. */
    int multi_component_target;
    /* The iterative solve, for reports ("Newton", "Gauss-Newton"); NULL
     * when not iterative.  A method with several solvers names the
     * default's here (an output's result says only which method made it)
     * and each plan's through solver_of. */
    const char *solver_name;
    /* NULL, or the solve a plan with these parameters runs (a method with
     * several solvers); see dtx_transfer_solver_name. */
    const char *(*solver_of)(const dtx_transfer_params *prm);
    /* 1: frame infos carry inverted (iterative methods only). */
    int counts_inverted;
    /* 1: frame infos carry grad_norm (iterative methods only). */
    int reports_grad_norm;
    /* Its settings (nsettings rows; NULL, 0 for a method without any),
     * in the job file's method object named after the method. */
    const dtx_setting *settings;
    int nsettings;

    /* Precompute for one target; prm->kind must be this method's kind.
     * Errors as the method's own plan_create. */
    dtx_status (*plan_create)(const dtx_transfer_inputs *in, const dtx_transfer_params *prm,
                              void **plan, dtx_error *err);
    /* Transfers nframes frames Xs (nframes x nv_src x 3) into Xt (nframes x
     * nv_tgt x 3, caller-allocated); info: nframes entries.  Per-call
     * scratch is kept in the plan and only grows, so calls with a fixed
     * block size allocate once.  Not thread-safe on one plan. */
    dtx_status (*apply)(void *plan, int64_t nframes, const double *Xs, double *Xt,
                        dtx_frame_info *info, dtx_error *err);
    /* NULL, or apply with the groups (of solve_group frames) dealt by the
     * caller's own team of threads, for a caller whose threads have other
     * work too (a rank's I/O thread joins the transfers when its I/O is
     * done).  team_prepare, before the parallel region, readies the plan
     * for omp_get_max_threads() threads (errors as apply's).  Then any
     * thread of the region may call team_apply on one block (the same
     * arguments in every call) whenever it is free: each call takes the
     * block's groups one at a time from *next (shared, zeroed before the
     * region, taken atomically) until none are left, transfers each on the
     * calling thread with that thread's scratch (omp_get_thread_num()),
     * and returns.  When every call has returned, Xt and info hold what
     * apply gives, bit for bit. */
    dtx_status (*team_prepare)(void *plan, dtx_error *err);
    void (*team_apply)(void *plan, int64_t nframes, const double *Xs, double *Xt,
                       dtx_frame_info *info, int64_t *next);
    /* Frees *plan (NULL allowed) and sets it to NULL. */
    void (*plan_free)(void **plan);
    /* What the plan holds, for a report: lines separated by '\n' (no final
     * one) into buf (size bytes); "" when the method has nothing to say. */
    void (*describe)(const void *plan, char *buf, size_t size);
} dtx_transfer_method;

extern const dtx_transfer_method dtx_method_sp04;           /* transfer_sp04.c */
extern const dtx_transfer_method dtx_method_multicomponent; /* transfer_mc.c */
extern const dtx_transfer_method dtx_method_springs;        /* springs.c */
extern const dtx_transfer_method dtx_method_biharmonic;     /* transfer_bh.c */

/* The table of a kind (NULL for an unknown one). */
const dtx_transfer_method *dtx_transfer_method_of(dtx_transfer_kind kind);
/* The table whose name is name, as a job file or an output's "method"
 * attribute names it (NULL for an unknown name or NULL). */
const dtx_transfer_method *dtx_transfer_method_named(const char *name);

/* The iterative solve that method m runs with parameters prm, for
 * reports: m->solver_of(prm), or m->solver_name (NULL when m is not
 * iterative). */
const char *dtx_transfer_solver_name(const dtx_transfer_method *m, const dtx_transfer_params *prm);

/* For the methods' adapters: makes *buf hold at least n elements of size
 * bytes (*cap counts them), keeping it when it does.  DTX_ENOMEM. */
dtx_status dtx_transfer_scratch(void **buf, int64_t *cap, int64_t n, size_t size, dtx_error *err);

#endif /* DTX_TRANSFER_H */
