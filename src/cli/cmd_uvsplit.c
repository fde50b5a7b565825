/*
 * cmd_uvsplit.c: `dtx generate uvsplit`, an asset split along a UV seam and
 * a material boundary, written as OBJ with vt, vn, usemtl and mtllib.
 */
#include "cmd_uvsplit.h"

#include "cli_util.h"
#include "options.h"

#include "atomic_file.h"
#include "meshfile.h"
#include "uvsplit.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int uv_usage(const char *msg)
{
    fprintf(stderr, "dtx: generate: %s\n", msg);
    dtx_cli_print_usage(stderr, dtx_cli_find_name("generate"));
    return 2;
}

/* OUT.obj -> OUT.mtl (path) and its base name (for the mtllib line). */
static int mtl_names(const char *obj, char *path, size_t np, const char **base)
{
    size_t n = strlen(obj);
    const char *slash;
    if (n < 4 || strcmp(obj + n - 4, ".obj") != 0 || n + 1 > np)
        return -1;
    memcpy(path, obj, n - 4);
    memcpy(path + n - 4, ".mtl", 5);
    slash = strrchr(path, '/');
    *base = slash ? slash + 1 : path;
    return 0;
}

int dtx_cmd_generate_uvsplit(int argc, char **argv)
{
    const char *in = NULL, *outp = NULL, *base = NULL;
    char mtl[4200], what[256];
    int materials = 2;
    dtx_mesh m;
    dtx_uvsplit s;
    dtx_mesh_attrs a;
    dtx_error err;
    dtx_warner w = {dtx_cli_print_warning, NULL};
    char *names[2] = {"dtx_lower", "dtx_upper"};
    dtx_status st;
    dtx_atomic_file af;

    for (int i = 3; i < argc; i++) {
        if (strcmp(argv[i], "--materials") == 0) {
            if (i + 1 >= argc || (strcmp(argv[i + 1], "1") != 0 && strcmp(argv[i + 1], "2") != 0))
                return uv_usage("--materials must be 1 or 2");
            materials = argv[++i][0] - '0';
        } else if (argv[i][0] == '-' && argv[i][1]) {
            char msg[300];
            snprintf(msg, sizeof msg, "uvsplit does not take the option %.200s", argv[i]);
            return uv_usage(msg);
        } else if (!in) {
            in = argv[i];
        } else if (!outp) {
            outp = argv[i];
        } else {
            return uv_usage("uvsplit needs two files, IN and OUT.obj");
        }
    }
    if (!in || !outp)
        return uv_usage("uvsplit needs two files, IN and OUT.obj");
    if (mtl_names(outp, mtl, sizeof mtl, &base) != 0)
        return uv_usage("uvsplit writes OBJ: OUT must end in .obj");
    if (strcmp(in, outp) == 0 || strcmp(in, mtl) == 0)
        return uv_usage("the output would overwrite the input");

    memset(&m, 0, sizeof m);
    memset(&s, 0, sizeof s);
    memset(&a, 0, sizeof a);
    if ((st = dtx_mesh_read(in, &m, &w, &err)) != DTX_OK ||
        (st = dtx_mesh_validate(&m, in, &err)) != DTX_OK)
        goto fail;
    if ((st = dtx_uvsplit_make(&m, materials, &s, &err)) != DTX_OK) {
        dtx_error_prefix(&err, "%s", in);
        goto fail;
    }
    /* glTF-style: one uv and one normal per (split) vertex. */
    a.nuv = a.nn = s.mesh.nv;
    a.uv = s.uv;
    a.normals = s.normals;
    a.uv_faces = a.normal_faces = s.mesh.F;
    a.nmat = materials;
    a.material = s.material;
    a.material_names = names;
    a.mtllib = (char *)base;
    snprintf(what, sizeof what,
             "%s split along a cylindrical UV seam%s (dtx generate uvsplit): %d vertices, %d "
             "duplicated at the seam, %d where the materials meet",
             in, materials == 2 ? " and where two materials meet" : "", (int)s.mesh.nv,
             (int)s.nseam, (int)s.nmatcut);
    if ((st = dtx_atomic_open(&af, mtl, &err)) != DTX_OK)
        goto fail;
    fprintf(af.fp, "# dtx generate uvsplit\nnewmtl dtx_lower\nKd 0.8 0.5 0.2\n");
    if (materials == 2)
        fprintf(af.fp, "newmtl dtx_upper\nKd 0.2 0.5 0.8\n");
    if ((st = dtx_atomic_commit(&af, &err)) != DTX_OK)
        goto fail;
    st = dtx_obj_write_attrs(outp, s.mesh.V, NULL, s.mesh.nv, s.mesh.F, s.mesh.nf, &a, what,
                             &err);
    if (st != DTX_OK) {
        remove(mtl);
        goto fail;
    }
    fprintf(stderr, "dtx: generate uvsplit: %s: %d vertices (%d at the UV seam, %d at the "
                    "material boundary), %d triangles, %d material(s); %s\n",
            outp, (int)s.mesh.nv, (int)s.nseam, (int)s.nmatcut, (int)s.mesh.nf, materials, mtl);
    dtx_uvsplit_free(&s);
    dtx_mesh_free(&m);
    return 0;
fail:
    dtx_uvsplit_free(&s);
    dtx_mesh_free(&m);
    return dtx_cli_fail(&err);
}
