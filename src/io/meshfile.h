/*
 * meshfile.h: triangle meshes from and to OBJ, PLY and OFF files, and
 * marker sets from CSV files.
 *
 * Every reader fills a dtx_mesh (src/core/mesh.h): V is nv x 3 row-major
 * doubles, F is nf x 3 row-major int32 with 0-based vertex indices, whatever
 * base the file format uses.  Polygons with more than three vertices are
 * fan-triangulated (v0 v1 v2, v0 v2 v3, ...) and reported by ONE warning per
 * file.  Files are read whole into memory and parsed in place; lines of any
 * length are handled safely and may end in LF, CRLF or a lone CR.  Comment
 * lines may be of any length; a line that holds a record of a few fields
 * (see DTX_MESHFILE_MAX_LINE) is an error beyond that many bytes.  NUL bytes
 * in a text file are an error ("not a text file").  Only regular files are
 * read: a FIFO or a device is refused before reading ("x.obj: not a regular
 * file (a FIFO)"). 
 *
 * The readers check what a parser can check: the syntax, counts against the
 * file size before anything is allocated, face indices against the vertex
 * count, and finite coordinates.  They do not reject degenerate faces or
 * unreferenced vertices; dtx_mesh_validate does that later.
 *
 * Errors: every failure returns a status and, when err is non-NULL, a
 * message that starts with the file name (or the `name` given to a parse
 * function) and, for text formats, the 1-based line number:
 *   "cat.obj:12: malformed vertex line: expected 3 numbers, found 2"
 * Codes: DTX_EIO (cannot open/read/write), DTX_EPARSE (syntax, missing or
 * truncated data, not a text file), DTX_ERANGE (index or count out of
 * range, counts that the file size cannot hold), DTX_ENONFINITE (NaN or
 * infinite coordinate), DTX_ENOMEM, DTX_EINVAL (bad arguments).
 * On failure *out is left empty (zeroed), and nothing needs freeing.
 *
 * Numbers are parsed with strtod, so the C locale's decimal point is
 * assumed (dtx never calls setlocale).
 *
 * Thread-safety: all functions are reentrant; distinct calls may run
 * concurrently as long as they do not share output structs or a warner
 * whose callback is not itself thread-safe.
 */
#ifndef DTX_MESHFILE_H
#define DTX_MESHFILE_H

#include "markers.h"
#include "mesh.h"
#include "status.h"

#include <stddef.h>
#include <stdint.h>

/* The longest record line accepted, in bytes (end of line excluded).  It
 * applies only to lines that hold a fixed handful of fields: an OBJ `v`
 * line, the OFF header, counts and vertex lines, a non-comment PLY header
 * line and a marker CSV data line.  Such a line holds a few numbers (and a
 * marker label), so a megabyte of it means the file is not what its name
 * says (binary data without NUL bytes, a wrong file), and saying so names
 * the problem better than a parse error somewhere inside it; it also bounds
 * the label each marker may carry.  Comment lines, lines a reader skips and
 * face lines (a polygon's line grows with its vertex count) may be of any
 * length: the readers never copy a whole line. */
#define DTX_MESHFILE_MAX_LINE ((size_t)1 << 20)

/* ------------------------------------------------------------ warnings */

/* Receives one warning message (a full sentence naming the file); msg is
 * only valid during the call. */
typedef void (*dtx_warn_fn)(void *ctx, const char *msg);

/* Where warnings go.  A NULL dtx_warner pointer or a NULL fn drops them. */
typedef struct {
    dtx_warn_fn fn;
    void *ctx;
} dtx_warner;

/* ------------------------------------------------------------ attributes */

/* What an asset carries besides positions and faces (all optional: a NULL
 * array is absent).  Per-corner attributes have their own index arrays,
 * nf x 3 like F, so vertices split along seams need not be split here:
 *   uv: nuv x 2 doubles, uv_faces: nf x 3 int32 into uv;
 *   normals: nn x 3 doubles, normal_faces: nf x 3 int32 into normals;
 *   material: nf int32 in [0, nmat) or -1 (no material), with nmat names;
 *   mtllib: the OBJ material library, kept by reference (a file name);
 *   colors: nv x ncolor (3 or 4) doubles in [0, 1], per vertex.
 * Free with dtx_mesh_attrs_free. */
typedef struct {
    int32_t nuv;
    double *uv;
    int32_t *uv_faces;
    int32_t nn;
    double *normals;
    int32_t *normal_faces;
    int32_t nmat;
    int32_t *material;
    char **material_names;
    char *mtllib;
    int32_t ncolor;
    double *colors;
} dtx_mesh_attrs;

/* Frees every array and zeroes *a.  Accepts NULL. */
void dtx_mesh_attrs_free(dtx_mesh_attrs *a);

/* 1 when a holds anything. */
int dtx_mesh_attrs_any(const dtx_mesh_attrs *a);

/* Checks a against a mesh of nv vertices and nf faces: counts >= 0, index
 * arrays present with their data and in range, material in [-1, nmat),
 * names present, finite values, colour channels 3 or 4.  what names the
 * mesh in the message. */
dtx_status dtx_mesh_attrs_validate(const dtx_mesh_attrs *a, int32_t nv, int32_t nf,
                                   const char *what, dtx_error *err);

/* ------------------------------------------------------------ reading */

/* The attributes of an OBJ file whose mesh (nf triangles after fan
 * triangulation) dtx_obj_read has read: vt (u v [w]) and vn lines, the
 * t and n parts of face references (1-based or negative), usemtl (one
 * material index per triangle, -1 before the first usemtl; names in order
 * of first use) and mtllib (the rest of its line, by reference).  UVs (or
 * normals) are kept only when every face corner references one.  *a is
 * zeroed first; free with dtx_mesh_attrs_free. */
dtx_status dtx_obj_read_attrs(const char *path, int32_t nf, dtx_mesh_attrs *a, dtx_error *err);
dtx_status dtx_obj_parse_attrs(const char *name, const char *buf, size_t len, int32_t nf,
                               dtx_mesh_attrs *a, dtx_error *err);

/* Reads a mesh, choosing the format by the extension of path (.obj, .ply,
 * .off; case-insensitive).  Another extension is DTX_EINVAL.  out is
 * overwritten (not freed first); the caller frees it with dtx_mesh_free. */
dtx_status dtx_mesh_read(const char *path, dtx_mesh *out, const dtx_warner *w, dtx_error *err);

/* Wavefront OBJ.  Reads `v x y z [w]` (w ignored; trailing vertex colours
 * `v x y z r g b` or `v x y z w r g b` tolerated and ignored) and `f` lines
 * whose references are `i`, `i/t`, `i//n` or `i/t/n`, 1-based or negative
 * (relative to the vertices defined so far).  vn, vt, vp, o, g, s, usemtl,
 * mtllib, l and comments are ignored silently; other keywords are ignored
 * with one warning per file naming the first such line.  Vertex numbers in
 * messages are 1-based, as in the file's face lines. */
dtx_status dtx_obj_read(const char *path, dtx_mesh *out, const dtx_warner *w, dtx_error *err);

/* As dtx_obj_read, from the len bytes at buf (need not be NUL-terminated;
 * never read beyond buf + len).  name is used in messages only. */
dtx_status dtx_obj_parse(const char *name, const char *buf, size_t len, dtx_mesh *out,
                         const dtx_warner *w, dtx_error *err);

/* Stanford PLY: ascii, binary_little_endian and binary_big_endian.  Needs an
 * `element vertex` with scalar x, y, z properties (any numeric type; other
 * properties, lists included, are skipped) and an `element face` with a list
 * property `vertex_indices` or `vertex_index` (integer count and item
 * types).  Other elements are skipped.  Vertex numbers in messages are
 * 0-based, as in the file.  Binary locations are given as byte offsets
 * from the start of the file. */
dtx_status dtx_ply_read(const char *path, dtx_mesh *out, const dtx_warner *w, dtx_error *err);
dtx_status dtx_ply_parse(const char *name, const char *buf, size_t len, dtx_mesh *out,
                         const dtx_warner *w, dtx_error *err);

/* The per-vertex attributes of a PLY file whose mesh (nf triangles)
 * dtx_ply_read has read, in a pass of their own: colours (red, green,
 * blue [, alpha], also diffuse_red..; integer types scaled to [0, 1] by
 * their largest value, float kept; a value outside [0, 1] drops the
 * colours with a warning), normals (nx, ny, nz) and texture coordinates
 * (s, t / u, v / texture_u, texture_v / texture_s, texture_t; the first
 * pair wins), in ascii and binary files.  Normals and UVs are stored per
 * vertex: nn (nuv) = nv and normal_faces (uv_faces) = the faces.  A
 * non-finite normal or UV is DTX_ENONFINITE.  Only the attributes'
 * warnings go to w (the mesh's own were given by dtx_ply_read).  *a is
 * zeroed first; free with dtx_mesh_attrs_free. */
dtx_status dtx_ply_read_attrs(const char *path, int32_t nf, dtx_mesh_attrs *a,
                              const dtx_warner *w, dtx_error *err);
dtx_status dtx_ply_parse_attrs(const char *name, const char *buf, size_t len, int32_t nf,
                               dtx_mesh_attrs *a, const dtx_warner *w, dtx_error *err);

/* Object File Format (ASCII): an `OFF` header line (also COFF, NOFF, CNOFF,
 * STOFF...; 4OFF, nOFF and binary OFF are rejected), a counts line
 * `nv nf [ne]` (may share the header line), nv vertex lines with at least
 * x y z (extra values such as colours ignored), nf face lines `n i1 .. in`
 * with 0-based indices (extra values such as colours ignored).  '#' starts
 * a comment anywhere on a line; blank lines are skipped. */
dtx_status dtx_off_read(const char *path, dtx_mesh *out, const dtx_warner *w, dtx_error *err);
dtx_status dtx_off_parse(const char *name, const char *buf, size_t len, dtx_mesh *out,
                         const dtx_warner *w, dtx_error *err);

/* ------------------------------------------------------------ writing */

/* Writes an OBJ file: a '#' comment header (the dtx version, the counts,
 * then `comment` if non-NULL, one '#' line per line of it), nv `v` lines,
 * nf `f` lines with 1-based indices.
 *   V: nv x 3 row-major doubles, written with %.17g (round-trips exactly).
 *   F: nf x 3 row-major int32, 0-based.
 * Indices out of [0, nv) are DTX_ERANGE and non-finite coordinates are
 * DTX_ENONFINITE, both detected before the file is created.  The file is
 * written atomically: a temporary file in the same directory, fsync, rename
 * over path; on any error no file (partial or temporary) is left behind and
 * an existing file at path is untouched. */
dtx_status dtx_obj_write(const char *path, const double *V, int32_t nv, const int32_t *F,
                         int32_t nf, const char *comment, dtx_error *err);

/* As dtx_obj_write, for float32 positions (result frames), written with
 * %.9g (round-trips float32 exactly). */
dtx_status dtx_obj_write_f32(const char *path, const float *V, int32_t nv, const int32_t *F,
                             int32_t nf, const char *comment, dtx_error *err);

/* Writes an OBJ file as dtx_obj_write, with the attributes a carries (a
 * may be NULL): `mtllib`, `vt` and `vn` lines, faces `f v/t/n` and
 * `usemtl` before each run of faces with the same material.  a is checked
 * with dtx_mesh_attrs_validate before the file is created.  V: nv x 3
 * doubles (Vd) or floats (Vf): exactly one non-NULL.  Normals are
 * written as a holds them (not recomputed for deformed positions). */
dtx_status dtx_obj_write_attrs(const char *path, const double *Vd, const float *Vf, int32_t nv,
                               const int32_t *F, int32_t nf, const dtx_mesh_attrs *a,
                               const char *comment, dtx_error *err);

/* ------------------------------------------------------------ markers */

/* Reads source/target vertex correspondences from a CSV file with lines
 * `source_vertex,target_vertex[,label]` (blanks around fields and double
 * quotes around an index are allowed).  The label is the rest of the line
 * after the second comma, trimmed (it may contain spaces and commas;
 * surrounding double quotes are removed, "" inside them becomes ").  Blank
 * lines and lines starting with '#' are skipped; one header line (whose
 * first field is not an integer) is allowed as the first non-comment line.
 *
 * index_base: 0 or 1, the base of the indices in the file, or -1 to take it
 * from a comment line `# index_base: 0` (or 1) in the file, which is an
 * error (DTX_EINVAL) when the file has none.  When both are given they must
 * agree (DTX_EINVAL otherwise).  Indices are stored 0-based; an index below
 * the base (index 0 in a 1-based file, a negative index) is DTX_ERANGE.
 * Ranges against the meshes are checked later by dtx_markers_validate.
 *
 * out is overwritten (not freed first); every label is allocated (possibly
 * ""); free with dtx_markers_free.  A file with no markers is DTX_EPARSE. */
dtx_status dtx_markers_read_csv(const char *path, int index_base, dtx_markers *out, dtx_error *err);

/* As dtx_markers_read_csv, from the len bytes at buf (need not be
 * NUL-terminated).  name is used in messages only. */
dtx_status dtx_markers_parse_csv(const char *name, const char *buf, size_t len, int index_base,
                                 dtx_markers *out, dtx_error *err);

#endif /* DTX_MESHFILE_H */
