/*
 * cmd_generate.c: `dtx generate pebbles|garment|eyes|reshape|subdivide IN OUT
 * [options]`.
 *
 * Reads one mesh, runs a generator of src/gen/generate.h, and writes the
 * result as OBJ, optionally with its vertex map ("generated_vertex,
 * original_vertex" rows, 0-based) and a marker file rewritten for the new
 * mesh (each target vertex replaced by the lowest output vertex made from
 * it; source vertices, labels and the index base kept).  Everything is
 * computed and checked before the first file is written; every file is
 * written atomically, and when a later one fails the ones already written by
 * this run are removed.
 */
#include "cmd_generate.h"
#include "cmd_uvsplit.h"

#include "cli_util.h"
#include "options.h"

#include "atomic_file.h"
#include "dtx_core.h"
#include "generate.h"
#include "meshfile.h"

#include <errno.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { KIND_PEBBLES, KIND_GARMENT, KIND_EYES, KIND_RESHAPE, KIND_SUBDIVIDE };

/* Every option takes a value; `kinds` says which generators accept it
 * (bit 1 << KIND_*). */
#define ALL_KINDS 31
static const struct {
    const char *name;
    int kinds;
} options[] = {
    {"--pieces", 1 << KIND_PEBBLES},
    {"--thickness", 1 << KIND_PEBBLES},
    {"--subdivide", 1 << KIND_PEBBLES},
    {"--gap", (1 << KIND_PEBBLES) | (1 << KIND_EYES)},
    {"--axis", (1 << KIND_GARMENT) | (1 << KIND_RESHAPE)},
    {"--lo", (1 << KIND_GARMENT) | (1 << KIND_RESHAPE)},
    {"--thicken", 1 << KIND_RESHAPE},
    {"--legs", 1 << KIND_RESHAPE},
    {"--hi", 1 << KIND_GARMENT},
    {"--offset", 1 << KIND_GARMENT},
    {"--anchors", 1 << KIND_EYES},
    {"--radius", 1 << KIND_EYES},
    {"--levels", 1 << KIND_SUBDIVIDE},
    {"--map", ALL_KINDS},
    {"--markers", ALL_KINDS},
    {"--index-base", ALL_KINDS},
    {"--markers-out", ALL_KINDS},
};
#define NOPTIONS ((int)(sizeof options / sizeof *options))

typedef struct {
    int kind;
    const char *kind_name;
    const char *in, *out;
    const char *val[NOPTIONS]; /* value of options[i], or NULL */
} gen_args;

static int usage_error(const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 1, 2)))
#endif
    ;

/* Prints "dtx: generate: MESSAGE" and the usage lines; returns 2. */
static int usage_error(const char *fmt, ...)
{
    va_list ap;
    fputs("dtx: generate: ", stderr);
    va_start(ap, fmt);
    vfprintf(stderr, fmt, ap);
    va_end(ap);
    fputc('\n', stderr);
    dtx_cli_print_usage(stderr, dtx_cli_find_name("generate"));
    return 2;
}

static const char *val(const gen_args *g, const char *name)
{
    for (int i = 0; i < NOPTIONS; i++)
        if (strcmp(options[i].name, name) == 0)
            return g->val[i];
    return NULL;
}

/* Whole-string number parsing; 0 on success. */
static int parse_double(const char *s, double *out)
{
    char *end;
    errno = 0;
    *out = strtod(s, &end);
    return end == s || *end != '\0' || errno == ERANGE || !isfinite(*out) ? -1 : 0;
}

static int parse_int(const char *s, long lo, long hi, long *out)
{
    char *end;
    errno = 0;
    *out = strtol(s, &end, 10);
    return end == s || *end != '\0' || errno == ERANGE || *out < lo || *out > hi ? -1 : 0;
}

/* A number option with a default; returns 0, or a usage error's 2. */
static int num_opt(const gen_args *g, const char *name, double def, double *out)
{
    const char *s = val(g, name);
    *out = def;
    if (s && parse_double(s, out) != 0)
        return usage_error("%s must be a finite number (got '%s')", name, s);
    return 0;
}

/* The --axis option given (the caller checked it is there): x, y or z (or
 * 0, 1, 2) -> 0, 1, 2; returns 0, or a usage error's 2. */
static int axis_opt(const gen_args *g, int *axis)
{
    const char *ax = val(g, "--axis");
    if (strlen(ax) != 1 || !strchr("xyz012", ax[0]))
        return usage_error("--axis must be x, y or z (got '%s')", ax);
    *axis = ax[0] >= 'x' ? ax[0] - 'x' : ax[0] - '0';
    return 0;
}

/* "I,J,K" -> a new array of 0-based vertex indices. */
static int parse_anchors(const char *s, int32_t **out, int32_t *n)
{
    int32_t cap = 1, k = 0;
    const char *p = s;
    for (const char *q = s; *q; q++)
        cap += *q == ',';
    *out = malloc((size_t)cap * sizeof **out);
    if (!*out)
        return -1;
    for (;;) {
        char buf[32];
        const char *e = strchr(p, ',');
        size_t len = e ? (size_t)(e - p) : strlen(p);
        long v;
        if (len == 0 || len >= sizeof buf)
            goto bad;
        memcpy(buf, p, len);
        buf[len] = '\0';
        if (parse_int(buf, 0, INT32_MAX - 1, &v) != 0)
            goto bad;
        (*out)[k++] = (int32_t)v;
        if (!e)
            break;
        p = e + 1;
    }
    *n = k;
    return 0;
bad:
    free(*out);
    *out = NULL;
    return -1;
}

static int parse_args(int argc, char **argv, gen_args *g)
{
    int npos = 0;
    memset(g, 0, sizeof *g);
    if (argc < 3)
        return usage_error("generate what? pebbles, garment, eyes, reshape or subdivide");
    g->kind_name = argv[2];
    if (strcmp(argv[2], "pebbles") == 0)
        g->kind = KIND_PEBBLES;
    else if (strcmp(argv[2], "garment") == 0)
        g->kind = KIND_GARMENT;
    else if (strcmp(argv[2], "eyes") == 0)
        g->kind = KIND_EYES;
    else if (strcmp(argv[2], "reshape") == 0)
        g->kind = KIND_RESHAPE;
    else if (strcmp(argv[2], "subdivide") == 0)
        g->kind = KIND_SUBDIVIDE;
    else
        return usage_error("unknown generator '%s' (pebbles, garment, eyes, reshape or subdivide)",
                           argv[2]);
    for (int i = 3; i < argc; i++) {
        const char *a = argv[i];
        if (a[0] == '-' && a[1] == '-') {
            int k;
            for (k = 0; k < NOPTIONS && strcmp(options[k].name, a) != 0; k++)
                ;
            if (k == NOPTIONS || !(options[k].kinds & (1 << g->kind)))
                return usage_error("%s does not take the option %s", g->kind_name, a);
            if (i + 1 >= argc)
                return usage_error("%s needs a value", a);
            if (g->val[k])
                return usage_error("%s given twice", a);
            g->val[k] = argv[++i];
        } else if (a[0] == '-' && a[1] != '\0') {
            return usage_error("unknown option %s", a);
        } else {
            if (npos == 0)
                g->in = a;
            else if (npos == 1)
                g->out = a;
            npos++;
        }
    }
    if (npos != 2)
        return usage_error("%s needs two files, IN and OUT.obj (got %s)", g->kind_name,
                           npos < 2 ? "fewer" : "more");
    {
        const char *mk = val(g, "--markers"), *ib = val(g, "--index-base"),
                   *mo = val(g, "--markers-out"), *mp = val(g, "--map");
        const char *outs[3] = {g->out, mp, mo};
        if ((mk != NULL) != (mo != NULL) || (mk != NULL) != (ib != NULL))
            return usage_error("--markers, --index-base and --markers-out go together");
        if (ib && strcmp(ib, "0") != 0 && strcmp(ib, "1") != 0)
            return usage_error("--index-base must be 0 or 1 (got '%s')", ib);
        for (int i = 0; i < 3; i++)
            for (int j = i + 1; j < 3; j++)
                if (outs[i] && outs[j] && strcmp(outs[i], outs[j]) == 0)
                    return usage_error("the output files must differ ('%s' named twice)", outs[i]);
        for (int i = 0; i < 3; i++)
            if (outs[i] && (strcmp(outs[i], g->in) == 0 || (mk && strcmp(outs[i], mk) == 0)))
                return usage_error("output '%s' would overwrite an input", outs[i]);
    }
    return 0;
}

/* Writes a label for the marker CSV, quoted when it would not read back. */
static void write_label(FILE *fp, const char *s)
{
    size_t n = strlen(s);
    if (n > 0 &&
        (strpbrk(s, ",\"") || s[0] == ' ' || s[0] == '\t' || s[n - 1] == ' ' || s[n - 1] == '\t')) {
        fputc('"', fp);
        for (const char *p = s; *p; p++) {
            if (*p == '"')
                fputc('"', fp);
            fputc(*p, fp);
        }
        fputc('"', fp);
    } else {
        fputs(s, fp);
    }
}

static dtx_status write_map(const char *path, const int32_t *map, int32_t nv, dtx_error *err)
{
    dtx_atomic_file af;
    dtx_status st = dtx_atomic_open(&af, path, err);
    if (st != DTX_OK)
        return st;
    fputs("generated_vertex,original_vertex\n", af.fp);
    for (int32_t v = 0; v < nv; v++)
        fprintf(af.fp, "%d,%d\n", (int)v, (int)map[v]);
    return dtx_atomic_commit(&af, err);
}

static dtx_status write_markers(const char *path, const dtx_markers *mk, const int32_t *tgt,
                                int base, const char *from, dtx_error *err)
{
    dtx_atomic_file af;
    dtx_status st = dtx_atomic_open(&af, path, err);
    if (st != DTX_OK)
        return st;
    fprintf(af.fp,
            "# %s rewritten by dtx generate for its output mesh\n# index_base: %d\n"
            "source_vertex,target_vertex,label\n",
            from, base);
    for (int32_t i = 0; i < mk->n; i++) {
        fprintf(af.fp, "%d,%d,", (int)(mk->src[i] + base), (int)(tgt[i] + base));
        write_label(af.fp, mk->labels && mk->labels[i] ? mk->labels[i] : "");
        fputc('\n', af.fp);
    }
    return dtx_atomic_commit(&af, err);
}

/* The generator's parameters, parsed from the options. */
typedef struct {
    long pieces, subdivide;     /* pebbles; subdivide also subdivide's --levels */
    double gap, thickness;      /* pebbles; gap also eyes */
    int axis;                   /* garment */
    double lo, hi, offset;      /* garment */
    int32_t *anchors, nanchors; /* eyes (owned) */
    double radius;              /* eyes */
    double thicken, legs;       /* reshape (also axis, lo) */
} gen_params;

/* Parses and checks the generator's options before anything is read.
 * Returns 0, or 2 after a usage message. */
static int parse_params(const gen_args *g, gen_params *p)
{
    int r;
    memset(p, 0, sizeof *p);
    if (g->kind == KIND_PEBBLES) {
        const char *ps = val(g, "--pieces"), *ss = val(g, "--subdivide");
        if (!ps)
            return usage_error("pebbles needs --pieces N");
        if (parse_int(ps, 1, INT32_MAX, &p->pieces) != 0)
            return usage_error("--pieces must be an integer >= 1 (got '%s')", ps);
        if (ss && parse_int(ss, 0, DTX_GEN_MAX_SUBDIVIDE, &p->subdivide) != 0)
            return usage_error("--subdivide must be an integer in [0, %d] (got '%s')",
                               DTX_GEN_MAX_SUBDIVIDE, ss);
        if ((r = num_opt(g, "--gap", 0.003, &p->gap)) ||
            (r = num_opt(g, "--thickness", 0, &p->thickness)))
            return r;
        if (p->gap < 0 || p->thickness < 0)
            return usage_error("--gap and --thickness must be >= 0");
    } else if (g->kind == KIND_SUBDIVIDE) {
        const char *ls = val(g, "--levels");
        if (!ls)
            return usage_error("subdivide needs --levels L");
        if (parse_int(ls, 0, DTX_GEN_MAX_SUBDIVIDE, &p->subdivide) != 0)
            return usage_error("--levels must be an integer in [0, %d] (got '%s')",
                               DTX_GEN_MAX_SUBDIVIDE, ls);
    } else if (g->kind == KIND_RESHAPE) {
        if (!val(g, "--axis"))
            return usage_error("reshape needs --axis (the up axis: x, y or z)");
        if ((r = axis_opt(g, &p->axis)) || (r = num_opt(g, "--thicken", 1.25, &p->thicken)) ||
            (r = num_opt(g, "--legs", 1.4, &p->legs)) || (r = num_opt(g, "--lo", 0.35, &p->lo)))
            return r;
        if (!(p->thicken > 0) || !(p->legs > 0))
            return usage_error("--thicken and --legs must be > 0 (got %g and %g)", p->thicken,
                               p->legs);
        if (!(p->lo >= 0 && p->lo <= 1))
            return usage_error("--lo must be in [0, 1] (got %g)", p->lo);
    } else if (g->kind == KIND_GARMENT) {
        if (!val(g, "--axis") || !val(g, "--lo") || !val(g, "--hi"))
            return usage_error("garment needs --axis, --lo and --hi");
        if ((r = axis_opt(g, &p->axis)) || (r = num_opt(g, "--lo", 0, &p->lo)) ||
            (r = num_opt(g, "--hi", 0, &p->hi)) || (r = num_opt(g, "--offset", 0.01, &p->offset)))
            return r;
        if (!(p->lo < p->hi))
            return usage_error("--lo must be below --hi (got %g and %g)", p->lo, p->hi);
        if (!(p->offset > 0))
            return usage_error("--offset must be > 0 (got %g)", p->offset);
    } else {
        const char *as = val(g, "--anchors");
        if (!as)
            return usage_error("eyes needs --anchors I,J,... (0-based vertex indices)");
        if ((r = num_opt(g, "--radius", 0.005, &p->radius)) ||
            (r = num_opt(g, "--gap", 0.002, &p->gap)))
            return r;
        if (!(p->radius > 0))
            return usage_error("--radius must be > 0 (got %g)", p->radius);
        if (parse_anchors(as, &p->anchors, &p->nanchors) != 0)
            return usage_error("--anchors must be comma-separated 0-based vertex indices (got "
                               "'%s')",
                               as);
    }
    return 0;
}

/* Runs the chosen generator; describes what it made in `what`. */
static dtx_status run_generator(const gen_args *g, const gen_params *p, const dtx_mesh *in,
                                dtx_mesh *out, int32_t **map, char *what, size_t nwhat,
                                dtx_error *err)
{
    if (g->kind == KIND_PEBBLES) {
        snprintf(what, nwhat, "%ld pieces, gap %g, thickness %g, subdivide %ld", p->pieces, p->gap,
                 p->thickness, p->subdivide);
        return dtx_gen_pebbles(in, (int32_t)p->pieces, p->gap, p->thickness, (int)p->subdivide, out,
                               map, err);
    }
    if (g->kind == KIND_SUBDIVIDE) {
        snprintf(what, nwhat, "midpoint subdivision, %ld level%s", p->subdivide,
                 p->subdivide == 1 ? "" : "s");
        return dtx_gen_subdivide(in, (int)p->subdivide, out, map, err);
    }
    if (g->kind == KIND_RESHAPE) {
        snprintf(what, nwhat, "%g times thicker, legs below %g of the height along %c %g times "
                              "longer",
                 p->thicken, p->lo, "xyz"[p->axis], p->legs);
        return dtx_gen_reshape(in, p->axis, p->thicken, p->legs, p->lo, out, map, err);
    }
    if (g->kind == KIND_GARMENT) {
        snprintf(what, nwhat, "shell over %g..%g along %c, offset %g", p->lo, p->hi, "xyz"[p->axis],
                 p -> offset);
        return dtx_gen_garment(in, p->axis, p->lo, p->hi, p->offset, out, map, err);
    }
    snprintf(what, nwhat, "%d spheres, radius %g, gap %g", (int)p->nanchors, p->radius, p->gap);
    return dtx_gen_eyes(in, p->anchors, p->nanchors, p->radius, p->gap, out, map, err);
}

int dtx_cmd_generate(int argc, char **argv)
{
    gen_args g;
    gen_params prm;
    dtx_mesh in, out;
    dtx_markers mk;
    dtx_error err;
    dtx_warner w = {dtx_cli_print_warning, NULL};
    int32_t *map = NULL, *tgt = NULL, ncomp = -1, *comp = NULL;
    const char *mp, *mkpath, *mo;
    char what[256], comment[1024];
    int r, base = 0, wrote_obj = 0, wrote_map = 0;
    dtx_status st;

    if (argc >= 3 && strcmp(argv[2], "uvsplit") == 0)
        return dtx_cmd_generate_uvsplit(argc, argv);
    if ((r = parse_args(argc, argv, &g)) != 0 || (r = parse_params(&g, &prm)) != 0)
        return r;
    mp = val(&g, "--map");
    mkpath = val(&g, "--markers");
    mo = val(&g, "--markers-out");
    memset(&in, 0, sizeof in);
    memset(&out, 0, sizeof out);
    memset(&mk, 0, sizeof mk);
    if ((st = dtx_mesh_read(g.in, &in, &w, &err)) != DTX_OK)
        goto fail;
    if ((st = dtx_mesh_validate(&in, g.in, &err)) != DTX_OK)
        goto fail;
    if (mkpath) {
        base = val(&g, "--index-base")[0] - '0';
        if ((st = dtx_markers_read_csv(mkpath, base, &mk, &err)) != DTX_OK)
            goto fail;
    }
    if ((st = run_generator(&g, &prm, &in, &out, &map, what, sizeof what, &err)) != DTX_OK) {
        dtx_error_prefix(&err, "%s", g.in);
        goto fail;
    }

    /* Markers: every target vertex moves to its lowest copy. */
    if (mkpath) {
        int32_t bad;
        tgt = malloc((size_t)(mk.n > 0 ? mk.n : 1) * sizeof *tgt);
        if (!tgt) {
            st = dtx_seterr(&err, DTX_ENOMEM, "out of memory");
            goto fail;
        }
        memcpy(tgt, mk.tgt, (size_t)mk.n * sizeof *tgt);
        st = dtx_gen_remap(map, out.nv, in.nv, mk.n, tgt, &bad, &err);
        if (st != DTX_OK && bad >= 0) {
            const char *label = mk.labels && mk.labels[bad] ? mk.labels[bad] : "";
            if (st == DTX_ERANGE)
                dtx_seterr(&err, st,
                           "%s: marker %d (\"%s\"): target vertex %d is outside the "
                           "mesh %s (%d vertices, index base %d)",
                           mkpath, (int)bad, label, (int)(mk.tgt[bad] + base), g.in, (int)in.nv,
                           base);
            else
                dtx_seterr(&err, st,
                           "%s: marker %d (\"%s\"): target vertex %d of %s has no copy "
                           "in the generated mesh (it is in no face, or only in faces that "
                           "were not copied)",
                           mkpath, (int)bad, label, (int)(mk.tgt[bad] + base), g.in);
        }
        if (st != DTX_OK)
            goto fail;
    }

    comp = malloc((size_t)(out.nv > 0 ? out.nv : 1) * sizeof *comp);
    if (comp)
        ncomp = dtx_mesh_components(&out, comp);
    free(comp);

    /* ---------------------------------------------- write */
    snprintf(comment, sizeof comment, "dtx generate %s from %s: %s", g.kind_name, g.in, what);
    if ((st = dtx_obj_write(g.out, out.V, out.nv, out.F, out.nf, comment, &err)) != DTX_OK)
        goto fail;
    wrote_obj = 1;
    if (mp && (st = write_map(mp, map, out.nv, &err)) != DTX_OK)
        goto fail;
    wrote_map = mp != NULL;
    if (mkpath && (st = write_markers(mo, &mk, tgt, base, mkpath, &err)) != DTX_OK)
        goto fail;
    fprintf(stderr,
            "dtx: generate %s: %s -> %s: %s; %d vertices, %d faces, %d connected "
            "components\n",
            g.kind_name, g.in, g.out, what, (int)out.nv, (int)out.nf, (int)ncomp);
    r = 0;
    goto done;

fail:
    if (wrote_obj)
        remove(g.out);
    if (wrote_map)
        remove(mp);
    fprintf(stderr, "dtx: error: %s\n", err.msg);
    r = 1;
done:
    free(prm.anchors);
    free(tgt);
    free(map);
    dtx_markers_free(&mk);
    dtx_mesh_free(&out);
    dtx_mesh_free(&in);
    return r;
}
