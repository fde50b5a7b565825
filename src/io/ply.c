/* ply.c: Stanford PLY meshes (ascii and binary, either byte order), read. */
#include "meshfile.h"
#include "meshfile_util.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ------------------------------------------------------------------ types */

typedef enum { T_NONE = 0, T_I8, T_U8, T_I16, T_U16, T_I32, T_U32, T_F32, T_F64 } ply_type;

static const struct {
    const char *name, *alias;
    int size;
} ply_types[] = {
    {"", "", 0},           {"char", "int8", 1},     {"uchar", "uint8", 1},
    {"short", "int16", 2}, {"ushort", "uint16", 2}, {"int", "int32", 4},
    {"uint", "uint32", 4}, {"float", "float32", 4}, {"double", "float64", 8},
};

static ply_type type_of(const char *s, size_t n)
{
    for (int t = T_I8; t <= T_F64; t++)
        if ((strlen(ply_types[t].name) == n && memcmp(ply_types[t].name, s, n) == 0) ||
            (strlen(ply_types[t].alias) == n && memcmp(ply_types[t].alias, s, n) == 0))
            return (ply_type)t;
    return T_NONE;
}

static int is_int_type(ply_type t) { return t >= T_I8 && t <= T_U32; }

enum { FMT_ASCII, FMT_LE, FMT_BE };
enum { ROLE_SKIP = -1, ROLE_X = 0, ROLE_Y = 1, ROLE_Z = 2, ROLE_INDICES = 3 };
/* Vertex attributes (dtx_ply_read_attrs): colour, normal, texture
 * coordinates; value k of vertex i goes to A[NATTR * i + role - ROLE_R]. */
enum { ROLE_R = 4, ROLE_G, ROLE_B, ROLE_A, ROLE_NX, ROLE_NY, ROLE_NZ, ROLE_U, ROLE_V, ROLE_END };
#define NATTR (ROLE_END - ROLE_R)
enum { EL_OTHER, EL_VERTEX, EL_FACE };

typedef struct {
    ply_type type;       /* scalar type, or the item type of a list */
    ply_type count_type; /* T_NONE for a scalar */
    int role;
} ply_prop;

typedef struct {
    char name[32]; /* for messages; truncated */
    uint64_t count;
    int kind;
    size_t first, nprop; /* its properties: props[first .. first + nprop) */
} ply_elem;

/* The input cursor over the data after end_header. */
typedef struct {
    const char *name;
    const unsigned char *p; /* data */
    size_t len, pos;
    size_t base; /* offset of the data in the file, for messages */
    int fmt;
    long line; /* ascii: the line of the cursor */
} ply_in;

/* ------------------------------------------------------------------ values */

enum { V_OK = 0, V_END = -1, V_BAD = -2, V_RANGE = -3 };

/* Next ascii token, across lines. */
static const char *ascii_token(ply_in *in, size_t *n)
{
    const char *b = (const char *)in->p, *p = b + in->pos, *e = b + in->len, *s;
    while (p < e && (dtx_is_blank(*p) || *p == '\n')) {
        /* Lines end at "\n", "\r\n" or a lone "\r". */
        if (*p == '\n' || (*p == '\r' && (p + 1 == e || p[1] != '\n')))
            in->line++;
        p++;
    }
    if (p == e) {
        in->pos = in->len;
        return NULL;
    }
    s = p;
    while (p < e && !dtx_is_blank(*p) && *p != '\n')
        p++;
    in->pos = (size_t)(p - b);
    *n = (size_t)(p - s);
    return s;
}

static uint64_t load_uint(const unsigned char *p, int size, int big_endian)
{
    uint64_t u = 0;
    for (int k = 0; k < size; k++)
        u |= (uint64_t)p[big_endian ? size - 1 - k : k] << (8 * k);
    return u;
}

/* Reads one value of type t.  Integer types set *iv (and *dv); float types
 * set *dv.  Returns V_OK, V_END (no data left), V_BAD (an ascii token that
 * is not a number of that type) or V_RANGE (an integer outside the type). */
static int read_value(ply_in *in, ply_type t, double *dv, int64_t *iv)
{
    static const int64_t lo[] = {0, -128, 0, -32768, 0, INT32_MIN, 0};
    static const int64_t hi[] = {0, 127, 255, 32767, 65535, INT32_MAX, UINT32_MAX};
    if (in->fmt == FMT_ASCII) {
        size_t n;
        const char *s = ascii_token(in, &n);
        if (!s)
            return V_END;
        if (is_int_type(t)) {
            int r = dtx_parse_int64(s, n, iv);
            if (r == -1)
                return V_BAD;
            if (r == -2 || *iv < lo[t] || *iv > hi[t])
                return V_RANGE;
            *dv = (double)*iv;
        } else {
            if (dtx_parse_double(s, n, dv) != 0)
                return V_BAD;
            *iv = 0;
        }
        return V_OK;
    } else {
        int size = ply_types[t].size;
        uint64_t u;
        if (in->len - in->pos < (size_t)size)
            return V_END;
        u = load_uint(in->p + in->pos, size, in->fmt == FMT_BE);
        in->pos += (size_t)size;
        switch (t) {
        case T_I8:
            *iv = u >= 0x80 ? (int64_t)u - 0x100 : (int64_t)u;
            break;
        case T_I16:
            *iv = u >= 0x8000 ? (int64_t)u - 0x10000 : (int64_t)u;
            break;
        case T_I32:
            *iv = u >= 0x80000000u ? (int64_t)u - 0x100000000ll : (int64_t)u;
            break;
        case T_U8:
        case T_U16:
        case T_U32:
            *iv = (int64_t)u;
            break;
        case T_F32: {
            uint32_t u32 = (uint32_t)u;
            float f;
            memcpy(&f, &u32, sizeof f);
            *dv = f;
            *iv = 0;
            return V_OK;
        }
        case T_F64:
            memcpy(dv, &u, sizeof *dv);
            *iv = 0;
            return V_OK;
        default:
            return V_BAD;
        }
        *dv = (double)*iv;
        return V_OK;
    }
}

/* "name:LINE" for ascii data, "name (byte offset N)" for binary, N counted
 * from the start of the file (pos is relative to the data). */
static const char *where(const ply_in *in, size_t pos, char *buf, size_t n)
{
    if (in->fmt == FMT_ASCII)
        snprintf(buf, n, "%.700s:%ld", in->name, in->line);
    else
        snprintf(buf, n, "%.700s (byte offset %zu)", in->name, in->base + pos);
    return buf;
}

static dtx_status value_error(const ply_in *in, int r, size_t pos, const ply_elem *el,
                              uint64_t item, ply_type t, dtx_error *err)
{
    char wb[768];
    if (r == V_END)
        return dtx_seterr(err, DTX_EPARSE,
                          "%s: unexpected end of data in element '%s' item %llu (0-based) "
                          "(file truncated?)",
                          in->name, el->name, (unsigned long long)item);
    return dtx_seterr(err, r == V_RANGE ? DTX_ERANGE : DTX_EPARSE,
                      "%s: element '%s' item %llu (0-based): %s value of type %s",
                      where(in, pos, wb, sizeof wb), el->name, (unsigned long long)item,
                      r == V_RANGE ? "out-of-range" : "malformed", ply_types[t].name);
}

/* ------------------------------------------------------------------ header */

typedef struct {
    int fmt;
    ply_elem *elems;
    size_t nelem;
    ply_prop *props;
    size_t nprop;
    size_t data_start;
    long data_line; /* line number of the first data line (ascii) */
} ply_header;

static int grow(void **p, size_t *cap, size_t need, size_t size)
{
    void *np;
    size_t nc;
    if (need <= *cap)
        return 0;
    nc = *cap ? *cap * 2 : 8;
    if (nc < need)
        nc = need;
    if (nc > SIZE_MAX / size)
        return -1;
    np = realloc(*p, nc * size);
    if (!np)
        return -1;
    *p = np;
    *cap = nc;
    return 0;
}

static int tok_is(const char *t, size_t n, const char *lit)
{
    return t && strlen(lit) == n && memcmp(t, lit, n) == 0;
}

/* The attribute role of a vertex property name, or ROLE_SKIP. */
static int attr_role(const char *nm, size_t n)
{
    static const struct {
        const char *name;
        int role;
    } names[] = {{"red", ROLE_R},       {"green", ROLE_G},     {"blue", ROLE_B},
                 {"alpha", ROLE_A},     {"diffuse_red", ROLE_R}, {"diffuse_green", ROLE_G},
                 {"diffuse_blue", ROLE_B}, {"nx", ROLE_NX},    {"ny", ROLE_NY},
                 {"nz", ROLE_NZ},       {"s", ROLE_U},         {"t", ROLE_V},
                 {"u", ROLE_U},         {"v", ROLE_V},         {"texture_u", ROLE_U},
                 {"texture_v", ROLE_V}, {"texture_s", ROLE_U}, {"texture_t", ROLE_V}};
    for (size_t i = 0; i < sizeof names / sizeof *names; i++)
        if (tok_is(nm, n, names[i].name))
            return names[i].role;
    return ROLE_SKIP;
}

static dtx_status parse_header(const char *name, const char *buf, size_t len, ply_header *h,
                               dtx_error *err)
{
    dtx_lines it;
    const char *b, *e, *p, *t;
    size_t n, ecap = 0, pcap = 0;
    int have_format = 0, ended = 0, cr_only;
    char show[48];

    memset(h, 0, sizeof *h);
    dtx_lines_init(&it, buf, len);
    if (!dtx_lines_next(&it, &b, &e) || (size_t)(e - b) != 3 || memcmp(b, "ply", 3) != 0)
        return dtx_seterr(err, DTX_EPARSE, "%s: not a PLY file (the first line is not 'ply')",
                          name);
    /* The header's line ends (LF, CRLF or a lone CR) are those of its first
     * line; see data_start below. */
    cr_only = e < it.end && *e == '\r' && (e + 1 == it.end || e[1] != '\n');
    while (!ended && dtx_lines_next(&it, &b, &e)) {
        if (dtx_has_nul(b, (size_t)(e - b)))
            return dtx_seterr(err, DTX_EPARSE, "%s:%ld: NUL byte in the header", name, it.line);
        p = b;
        t = dtx_next_token(&p, e, &n);
        if (!t || tok_is(t, n, "comment") || tok_is(t, n, "obj_info"))
            continue; /* comments may be of any length */
        if ((size_t)(e - b) > DTX_MESHFILE_MAX_LINE)
            return dtx_seterr(err, DTX_EPARSE,
                              "%s:%ld: header line too long (%zu bytes; the limit is %zu)", name,
                              it.line, (size_t)(e - b), DTX_MESHFILE_MAX_LINE);
        if (tok_is(t, n, "end_header")) {
            ended = 1;
        } else if (tok_is(t, n, "format")) {
            t = dtx_next_token(&p, e, &n);
            if (tok_is(t, n, "ascii"))
                h->fmt = FMT_ASCII;
            else if (tok_is(t, n, "binary_little_endian"))
                h->fmt = FMT_LE;
            else if (tok_is(t, n, "binary_big_endian"))
                h->fmt = FMT_BE;
            else
                return dtx_seterr(err, DTX_EPARSE, "%s:%ld: unknown PLY format '%s'", name, it.line,
                                  t ? dtx_show_token(t, n, show, sizeof show) : "");
            /* 1.0 is the only PLY version there is: another one may mean
             * another layout, so it is not read as if it were 1.0. */
            t = dtx_next_token(&p, e, &n);
            if (!tok_is(t, n, "1.0"))
                return dtx_seterr(err, DTX_EPARSE,
                                  "%s:%ld: PLY version %s%s%s is not supported (only 1.0)", name,
                                  it.line, t ? "'" : "(none given)",
                                  t ? dtx_show_token(t, n, show, sizeof show) : "", t ? "'" : "");
            if (dtx_next_token(&p, e, &n))
                return dtx_seterr(err, DTX_EPARSE,
                                  "%s:%ld: unexpected text after 'format FORMAT 1.0'", name,
                                  it.line);
            have_format = 1;
        } else if (tok_is(t, n, "element")) {
            ply_elem *el;
            int64_t cnt;
            const char *nm = dtx_next_token(&p, e, &n);
            size_t nn = n;
            t = dtx_next_token(&p, e, &n);
            if (!nm || !t)
                return dtx_seterr(err, DTX_EPARSE, "%s:%ld: expected 'element NAME COUNT'", name,
                                  it.line);
            if (dtx_parse_int64(t, n, &cnt) != 0 || cnt < 0)
                return dtx_seterr(err, DTX_ERANGE, "%s:%ld: bad element count '%s'", name, it.line,
                                  dtx_show_token(t, n, show, sizeof show));
            if (grow((void **)&h->elems, &ecap, h->nelem + 1, sizeof *h->elems) != 0)
                return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", name);
            el = &h->elems[h->nelem++];
            memset(el, 0, sizeof *el);
            dtx_show_token(nm, nn, el->name, sizeof el->name);
            el->count = (uint64_t)cnt;
            el->kind = tok_is(nm, nn, "vertex") ? EL_VERTEX
                       : tok_is(nm, nn, "face") ? EL_FACE
                                                : EL_OTHER;
            el->first = h->nprop;
        } else if (tok_is(t, n, "property")) {
            ply_prop pr;
            ply_elem *el;
            const char *nm;
            if (h->nelem == 0)
                return dtx_seterr(err, DTX_EPARSE, "%s:%ld: property before any element", name,
                                  it.line);
            el = &h->elems[h->nelem - 1];
            memset(&pr, 0, sizeof pr);
            pr.role = ROLE_SKIP;
            t = dtx_next_token(&p, e, &n);
            if (tok_is(t, n, "list")) {
                t = dtx_next_token(&p, e, &n);
                pr.count_type = t ? type_of(t, n) : T_NONE;
                if (pr.count_type == T_NONE || !is_int_type(pr.count_type))
                    return dtx_seterr(err, DTX_EPARSE,
                                      "%s:%ld: list count type must be an integer type", name,
                                      it.line);
                t = dtx_next_token(&p, e, &n);
            }
            pr.type = t ? type_of(t, n) : T_NONE;
            if (pr.type == T_NONE)
                return dtx_seterr(err, DTX_EPARSE, "%s:%ld: unknown property type '%s'", name,
                                  it.line, t ? dtx_show_token(t, n, show, sizeof show) : "");
            nm = dtx_next_token(&p, e, &n);
            if (!nm)
                return dtx_seterr(err, DTX_EPARSE, "%s:%ld: property without a name", name,
                                  it.line);
            if (el->kind == EL_VERTEX && pr.count_type == T_NONE) {
                if (tok_is(nm, n, "x"))
                    pr.role = ROLE_X;
                else if (tok_is(nm, n, "y"))
                    pr.role = ROLE_Y;
                else if (tok_is(nm, n, "z"))
                    pr.role = ROLE_Z;
                else
                    pr.role = attr_role(nm, n);
            } else if (el->kind == EL_FACE && pr.count_type != T_NONE &&
                       (tok_is(nm, n, "vertex_indices") || tok_is(nm, n, "vertex_index"))) {
                if (!is_int_type(pr.type))
                    return dtx_seterr(err, DTX_EPARSE,
                                      "%s:%ld: face vertex indices must have an integer type", name,
                                      it.line);
                pr.role = ROLE_INDICES;
            }
            for (size_t k = el->first; k < h->nprop; k++)
                if (pr.role >= ROLE_R && h->props[k].role == pr.role)
                    pr.role = ROLE_SKIP; /* u after s, etc.: the first is kept */
            for (size_t k = el->first; k < h->nprop; k++)
                if (pr.role != ROLE_SKIP && h->props[k].role == pr.role)
                    return dtx_seterr(err, DTX_EPARSE, "%s:%ld: duplicate property '%s'", name,
                                      it.line, dtx_show_token(nm, n, show, sizeof show));
            if (grow((void **)&h->props, &pcap, h->nprop + 1, sizeof *h->props) != 0)
                return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", name);
            h->props[h->nprop++] = pr;
            el->nprop++;
        } else {
            return dtx_seterr(err, DTX_EPARSE, "%s:%ld: unknown header keyword '%s'", name, it.line,
                              dtx_show_token(t, n, show, sizeof show));
        }
    }
    if (!ended)
        return dtx_seterr(err, DTX_EPARSE, "%s: the header has no end_header line", name);
    if (!have_format)
        return dtx_seterr(err, DTX_EPARSE, "%s: the header has no format line", name);
    /* The data start right after end_header's line end.  With lone-CR line
     * ends a "\n" after that CR is already data (a binary body may start
     * with the byte 0x0A), so the iterator's "\r\n" is not trusted here. */
    {
        const char *d = e;
        if (d < it.end && *d == '\r') {
            d++;
            if (!cr_only && d < it.end && *d == '\n')
                d++;
        } else if (d < it.end && *d == '\n') {
            d++;
        }
        h->data_start = (size_t)(d - buf);
    }
    h->data_line = it.line + 1;
    return DTX_OK;
}

/* Checks the header's structure and that the data can hold what it
 * declares, before anything is allocated from its counts. */
static dtx_status check_header(const char *name, const ply_header *h, size_t data_len,
                               const ply_elem **vel, const ply_elem **fel, dtx_error *err)
{
    uint64_t need = 0;
    *vel = *fel = NULL;
    for (size_t i = 0; i < h->nelem; i++) {
        const ply_elem *el = &h->elems[i];
        uint64_t per = 0;
        if (el->kind == EL_VERTEX || el->kind == EL_FACE) {
            const ply_elem **slot = el->kind == EL_VERTEX ? vel : fel;
            if (*slot)
                return dtx_seterr(err, DTX_EPARSE, "%s: two '%s' elements", name, el->name);
            *slot = el;
        }
        if (el->nprop == 0 && el->count > 0)
            return dtx_seterr(err, DTX_EPARSE, "%s: element '%s' has no properties", name,
                              el->name);
        for (size_t k = el->first; k < el->first + el->nprop; k++) {
            const ply_prop *pr = &h->props[k];
            if (h->fmt == FMT_ASCII)
                per += 1; /* one token at least (a list's count) */
            else
                per +=
                    (uint64_t)ply_types[pr->count_type != T_NONE ? pr->count_type : pr->type].size;
        }
        /* ascii tokens need a separator each, except the last one */
        if (h->fmt == FMT_ASCII)
            per *= 2;
        if (el->count > 0 && per > (UINT64_MAX - need) / el->count)
            need = UINT64_MAX;
        else
            need += el->count * per;
    }
    if (h->fmt == FMT_ASCII && need > 0)
        need -= 1;
    if (!*vel)
        return dtx_seterr(err, DTX_EPARSE, "%s: no 'vertex' element", name);
    if (!*fel)
        return dtx_seterr(err, DTX_EPARSE, "%s: no 'face' element (point clouds are not meshes)",
                          name);
    for (int r = ROLE_X; r <= ROLE_Z; r++) {
        int found = 0;
        for (size_t k = (*vel)->first; k < (*vel)->first + (*vel)->nprop; k++)
            found |= h->props[k].role == r;
        if (!found)
            return dtx_seterr(err, DTX_EPARSE, "%s: element vertex has no scalar property '%c'",
                              name, "xyz"[r]);
    }
    {
        int found = 0;
        for (size_t k = (*fel)->first; k < (*fel)->first + (*fel)->nprop; k++)
            found |= h->props[k].role == ROLE_INDICES;
        if (!found)
            return dtx_seterr(err, DTX_EPARSE,
                              "%s: element face has no list property 'vertex_indices'", name);
    }
    if ((*vel)->count == 0)
        return dtx_seterr(err, DTX_EPARSE, "%s: no vertices (element vertex 0)", name);
    if ((*fel)->count == 0)
        return dtx_seterr(err, DTX_EPARSE, "%s: no faces (element face 0)", name);
    if ((*vel)->count > INT32_MAX || (*fel)->count > INT32_MAX)
        return dtx_seterr(err, DTX_ERANGE,
                          "%s: %llu vertices and %llu faces declared (at most %d of each are "
                          "supported)",
                          name, (unsigned long long)(*vel)->count,
                          (unsigned long long)(*fel)->count, (int)INT32_MAX);
    if (need > data_len)
        return dtx_seterr(err, DTX_ERANGE,
                          "%s: the header declares %llu vertices and %llu faces, which need at "
                          "least %llu bytes of data, but only %zu bytes follow the header (file "
                          "truncated or counts wrong)",
                          name, (unsigned long long)(*vel)->count,
                          (unsigned long long)(*fel)->count, (unsigned long long)need, data_len);
    return DTX_OK;
}

/* ------------------------------------------------------------------ body */

static dtx_status ply_attrs_build(const char *name, const ply_header *h, const ply_elem *vel,
                                  const double *A, const dtx_mesh *m, dtx_mesh_attrs *a,
                                  const dtx_warner *w, dtx_error *err);

/* dtx_ply_parse, and when a_out is non-NULL the vertex attributes into
 * *a_out, with their warnings to aw (dtx_ply_parse_attrs). */
static dtx_status ply_parse_impl(const char *name, const char *buf, size_t len, dtx_mesh *out,
                                 dtx_mesh_attrs *a_out, const dtx_warner *aw,
                                 const dtx_warner *w, dtx_error *err)
{
    double *A = NULL; /* nv x NATTR vertex attributes, when a_out */
    ply_header h;
    ply_in in;
    const ply_elem *vel, *fel;
    double *V = NULL;
    int32_t *F = NULL;
    size_t fcap;
    int64_t nt = 0, npoly = 0, nv;
    char wb[768];
    dtx_status st;

    memset(out, 0, sizeof *out);
    st = parse_header(name, buf, len, &h, err);
    if (st != DTX_OK)
        goto fail;
    st = check_header(name, &h, len - h.data_start, &vel, &fel, err);
    if (st != DTX_OK)
        goto fail;
    in.name = name;
    in.p = (const unsigned char *)buf + h.data_start;
    in.len = len - h.data_start;
    in.pos = 0;
    in.base = h.data_start;
    in.fmt = h.fmt;
    in.line = h.data_line;
    if (h.fmt == FMT_ASCII && dtx_has_nul((const char *)in.p, in.len)) {
        st = dtx_seterr(err, DTX_EPARSE, "%s: not a text file (NUL bytes in ascii PLY data)", name);
        goto fail;
    }
    nv = (int64_t)vel->count;
    fcap = (size_t)fel->count;
    V = dtx_alloc((size_t)nv, 3 * sizeof *V, 0);
    F = dtx_alloc(fcap, 3 * sizeof *F, 0);
    if (a_out)
        A = dtx_alloc((size_t)nv, NATTR * sizeof *A, 1);
    if (!V || !F || (a_out && !A)) {
        st = dtx_seterr(err, DTX_ENOMEM, "%s: cannot allocate %lld vertices", name, (long long)nv);
        goto fail;
    }

    for (size_t ei = 0; ei < h.nelem; ei++) {
        const ply_elem *el = &h.elems[ei];
        for (uint64_t item = 0; item < el->count; item++) {
            for (size_t k = el->first; k < el->first + el->nprop; k++) {
                const ply_prop *pr = &h.props[k];
                size_t pos = in.pos;
                double dv = 0;
                int64_t iv = 0, cnt, first = 0, prev = 0;
                int r;
                if (pr->count_type == T_NONE) {
                    /* ---- a scalar */
                    r = read_value(&in, pr->type, &dv, &iv);
                    if (r != V_OK) {
                        st = value_error(&in, r, pos, el, item, pr->type, err);
                        goto fail;
                    }
                    if (el->kind == EL_VERTEX && pr->role >= ROLE_X && pr->role <= ROLE_Z)
                        V[3 * item + (uint64_t)pr->role] = dv;
                    else if (A && el->kind == EL_VERTEX && pr->role >= ROLE_R)
                        A[NATTR * item + (uint64_t)(pr->role - ROLE_R)] = dv;
                    continue;
                }
                /* ---- a list: its count, then the items */
                r = read_value(&in, pr->count_type, &dv, &cnt);
                if (r == V_OK && cnt < 0)
                    r = V_RANGE;
                if (r != V_OK) {
                    st = value_error(&in, r, pos, el, item, pr->count_type, err);
                    goto fail;
                }
                if (pr->role != ROLE_INDICES) {
                    if (in.fmt != FMT_ASCII) {
                        uint64_t bytes = (uint64_t)cnt * (uint64_t)ply_types[pr->type].size;
                        if (bytes > in.len - in.pos) {
                            st = value_error(&in, V_END, pos, el, item, pr->type, err);
                            goto fail;
                        }
                        in.pos += (size_t)bytes;
                    } else {
                        for (int64_t j = 0; j < cnt; j++) {
                            r = read_value(&in, pr->type, &dv, &iv);
                            if (r != V_OK) {
                                st = value_error(&in, r, in.pos, el, item, pr->type, err);
                                goto fail;
                            }
                        }
                    }
                    continue;
                }
                if (cnt < 3) {
                    st = dtx_seterr(err, DTX_EPARSE,
                                    "%s: face %llu (0-based) has %lld vertices (at least 3 "
                                    "needed)",
                                    where(&in, pos, wb, sizeof wb), (unsigned long long)item,
                                    (long long)cnt);
                    goto fail;
                }
                for (int64_t j = 0; j < cnt; j++) {
                    pos = in.pos;
                    r = read_value(&in, pr->type, &dv, &iv);
                    if (r != V_OK) {
                        st = value_error(&in, r, pos, el, item, pr->type, err);
                        goto fail;
                    }
                    if (iv < 0 || iv >= nv) {
                        st = dtx_seterr(err, DTX_ERANGE,
                                        "%s: face %llu (0-based): vertex index %lld out of range "
                                        "[0, %lld)",
                                        where(&in, pos, wb, sizeof wb), (unsigned long long)item,
                                        (long long)iv, (long long)nv);
                        goto fail;
                    }
                    if (j == 0) {
                        first = iv;
                    } else if (j >= 2) {
                        if (nt == INT32_MAX) {
                            st = dtx_seterr(err, DTX_ERANGE, "%s: more than %d triangles", name,
                                            (int)INT32_MAX);
                            goto fail;
                        }
                        if (dtx_tri_push(&F, &fcap, &nt, (int32_t)first, (int32_t)prev, (int32_t)iv) !=
                            0) {
                            st = dtx_seterr(err, DTX_ENOMEM, "%s: out of memory", name);
                            goto fail;
                        }
                    }
                    prev = iv;
                }
                if (cnt > 3)
                    npoly++;
            }
            if (el->kind == EL_VERTEX && (!isfinite(V[3 * item]) || !isfinite(V[3 * item + 1]) ||
                                          !isfinite(V[3 * item + 2]))) {
                st = dtx_seterr(err, DTX_ENONFINITE,
                                "%s: vertex %llu (0-based) has a non-finite coordinate",
                                where(&in, in.pos, wb, sizeof wb), (unsigned long long)item);
                goto fail;
            }
        }
    }

    /* ---- anything after the last element is ignored, with a warning */
    if (in.fmt == FMT_ASCII) {
        size_t n;
        if (ascii_token(&in, &n))
            dtx_warnf(w, "%s:%ld: data after the last element ignored", name, in.line);
    } else if (in.pos < in.len) {
        dtx_warnf(w, "%s: %zu bytes of data after the last element ignored", name, in.len - in.pos);
    }
    if (npoly > 0)
        dtx_warnf(w, "%s: %lld polygons with more than 3 vertices were fan-triangulated", name,
                  (long long)npoly);
    dtx_mesh_take(out, nv, nt, V, F);
    if (a_out && (st = ply_attrs_build(name, &h, vel, A, out, a_out, aw, err)) != DTX_OK) {
        memset(out, 0, sizeof *out);
        goto fail;
    }
    free(A);
    free(h.elems);
    free(h.props);
    return DTX_OK;

fail:
    free(A);
    free(V);
    free(F);
    free(h.elems);
    free(h.props);
    return st;
}

dtx_status dtx_ply_parse(const char *name, const char *buf, size_t len, dtx_mesh *out,
                         const dtx_warner *w, dtx_error *err)
{
    return ply_parse_impl(name, buf, len, out, NULL, NULL, w, err);
}

dtx_status dtx_ply_read(const char *path, dtx_mesh *out, const dtx_warner *w, dtx_error *err)
{
    return dtx_mesh_read_with(path, dtx_ply_parse, out, w, err);
}

/* ------------------------------------------------------------------ attributes */

/* The largest value of an integer colour type (colours are scaled to
 * [0, 1] by it); 1 for floating-point types. */
static double colour_scale(ply_type t)
{
    switch (t) {
    case T_I8:
        return 127.0;
    case T_U8:
        return 255.0;
    case T_I16:
        return 32767.0;
    case T_U16:
        return 65535.0;
    case T_I32:
        return 2147483647.0;
    case T_U32:
        return 4294967295.0;
    default:
        return 1.0;
    }
}

/* Per-vertex attributes from the values A (nv x NATTR) of the roles the
 * vertex element has: colours (red, green, blue [, alpha]; integer types
 * scaled by their largest value), normals (nx, ny, nz) and texture
 * coordinates (u, v); per-corner indices equal to the faces. */
static dtx_status ply_attrs_build(const char *name, const ply_header *h, const ply_elem *vel,
                                  const double *A, const dtx_mesh *m, dtx_mesh_attrs *a,
                                  const dtx_warner *w, dtx_error *err)
{
    ply_type type[NATTR];
    int has[NATTR] = {0};
    int32_t nv = m->nv;
    size_t fbytes = 3 * (size_t)m->nf * sizeof *m->F;
    memset(a, 0, sizeof *a);
    for (int r = 0; r < NATTR; r++)
        type[r] = T_NONE;
    for (size_t k = vel->first; k < vel->first + vel->nprop; k++)
        if (h->props[k].role >= ROLE_R && h->props[k].count_type == T_NONE) {
            has[h->props[k].role - ROLE_R] = 1;
            type[h->props[k].role - ROLE_R] = h->props[k].type;
        }
#define HAS(r) has[(r)-ROLE_R]
    for (int32_t i = 0; i < nv; i++)
        for (int r = ROLE_NX; r <= ROLE_V; r++)
            if (HAS(r) && !isfinite(A[NATTR * (size_t)i + (size_t)(r - ROLE_R)]))
                return dtx_seterr(err, DTX_ENONFINITE,
                                  "%s: vertex %lld (0-based) has a non-finite %s", name,
                                  (long long)i, r <= ROLE_NZ ? "normal" : "texture coordinate");
    if (HAS(ROLE_R) && HAS(ROLE_G) && HAS(ROLE_B)) {
        int nc = HAS(ROLE_A) ? 4 : 3, ok = 1;
        a->colors = dtx_alloc((size_t)nv, (size_t)nc * sizeof *a->colors, 0);
        if (!a->colors && nv > 0)
            goto oom;
        a->ncolor = nc;
        for (int32_t i = 0; i < nv && ok; i++)
            for (int c = 0; c < nc && ok; c++) {
                double v = A[NATTR * (size_t)i + (size_t)c] / colour_scale(type[c]);
                a->colors[(size_t)nc * i + (size_t)c] = v;
                if (!(v >= 0 && v <= 1)) {
                    dtx_warnf(w, "%s: vertex %lld (0-based) has colour value %g outside [0, 1]; "
                                 "the colours are not kept",
                              name, (long long)i, v);
                    ok = 0;
                }
            }
        if (!ok) {
            free(a->colors);
            a->colors = NULL;
            a->ncolor = 0;
        }
    }
    if (HAS(ROLE_NX) && HAS(ROLE_NY) && HAS(ROLE_NZ) && m->nf > 0) {
        a->nn = nv;
        a->normals = dtx_alloc((size_t)nv, 3 * sizeof *a->normals, 0);
        a->normal_faces = malloc(fbytes);
        if (!a->normals || !a->normal_faces)
            goto oom;
        for (int32_t i = 0; i < nv; i++)
            for (int k = 0; k < 3; k++)
                a->normals[3 * (size_t)i + (size_t)k] =
                    A[NATTR * (size_t)i + (size_t)(ROLE_NX - ROLE_R + k)];
        memcpy(a->normal_faces, m->F, fbytes);
    }
    if (HAS(ROLE_U) && HAS(ROLE_V) && m->nf > 0) {
        a->nuv = nv;
        a->uv = dtx_alloc((size_t)nv, 2 * sizeof *a->uv, 0);
        a->uv_faces = malloc(fbytes);
        if (!a->uv || !a->uv_faces)
            goto oom;
        for (int32_t i = 0; i < nv; i++)
            for (int k = 0; k < 2; k++)
                a->uv[2 * (size_t)i + (size_t)k] =
                    A[NATTR * (size_t)i + (size_t)(ROLE_U - ROLE_R + k)];
        memcpy(a->uv_faces, m->F, fbytes);
    }
#undef HAS
    return DTX_OK;
oom:
    dtx_mesh_attrs_free(a);
    return dtx_seterr(err, DTX_ENOMEM, "%s: out of memory for the vertex attributes", name);
}

dtx_status dtx_ply_parse_attrs(const char *name, const char *buf, size_t len, int32_t nf,
                               dtx_mesh_attrs *a, const dtx_warner *w, dtx_error *err)
{
    dtx_mesh m;
    dtx_status st;
    memset(a, 0, sizeof *a);
    st = ply_parse_impl(name, buf, len, &m, a, w, NULL, err);
    if (st != DTX_OK)
        return st;
    if (m.nf != nf) {
        dtx_mesh_attrs_free(a);
        st = dtx_seterr(err, DTX_EINVAL, "%s: %d faces, but the mesh read has %d", name,
                        (int)m.nf, (int)nf);
    }
    dtx_mesh_free(&m);
    return st;
}

dtx_status dtx_ply_read_attrs(const char *path, int32_t nf, dtx_mesh_attrs *a,
                              const dtx_warner *w, dtx_error *err)
{
    char *buf = NULL;
    size_t len = 0;
    dtx_status st = dtx_file_read_all(path, &buf, &len, err);
    memset(a, 0, sizeof *a);
    if (st == DTX_OK)
        st = dtx_ply_parse_attrs(path, buf, len, nf, a, w, err);
    free(buf);
    return st;
}
