/*
 * h5_layout_text.c: schemas/hdf5-layout-v1.json compiled into the library,
 * so that `dtx validate` works without the source tree.  GENERATED: do not
 * edit by hand; after changing the JSON file, regenerate with
 *
 *   python3 - <<'PY'
 *   import json
 *   t = open('schemas/hdf5-layout-v1.json').read()
 *   body = ''.join('    %s,\n' % json.dumps(l) for l in t.splitlines(True))
 *   c = open('src/io/h5_layout_text.c').read()
 *   m = 'static const char *const lines[] = {\n'
 *   a = c.index(m) + len(m)
 *   b = c.index('    NULL\n};')
 *   open('src/io/h5_layout_text.c', 'w').write(c[:a] + body + c[b:])
 *   PY
 *
 * (tests/io/test_h5validate.c checks the copy equals the file byte for
 * byte).  The text is kept as one literal per line because ISO C compilers
 * need only accept string literals of 4095 characters.
 */
#include "h5layout.h"

#include <stdlib.h>
#include <string.h>

static const char *const lines[] = {
    "{\n",
    "  \"title\": \"dtx HDF5 layout\",\n",
    "  \"format\": \"dtx\",\n",
    "  \"format_version\": 1,\n",
    "  \"doc\": \"Machine-readable description of the dtx HDF5 layout, version 1, read by `dtx validate`. The readable specification is schemas/hdf5-layout-v1.md. A copy of this file is compiled into dtx (src/io/h5_layout_text.c).\",\n",
    "  \"conventions\": {\n",
    "    \"strings\": \"Attributes and string datasets are written as variable-length UTF-8 strings (scalar dataspace for attributes). Readers also accept fixed-length strings.\",\n",
    "    \"byte_order\": \"little-endian\",\n",
    "    \"indices\": \"0-based\",\n",
    "    \"temporary_prefix\": \".dtx-tmp-\",\n",
    "    \"temporary_groups\": \"A writer creates PARENT/.dtx-tmp-NAME and renames it to PARENT/NAME when complete; a group with this prefix is left over from an interrupted writer and is not checked.\",\n",
    "    \"names\": \"Objects of a kind live below its group: /KIND/NAME, where NAME may have several components (/results/lion/cat-poses): a group below /KIND holding none of the kind's datasets is a namespace group and holds only groups.\",\n",
    "    \"references\": \"An attribute naming another object holds an absolute HDF5 path in the same file ('/meshes/lion'), 'FILE:PATH' for an object in another file (not followed by the validator), or '' when unknown.\",\n",
    "    \"attribute_ints\": \"Written as int32; any integer type is accepted.\"\n",
    "  },\n",
    "  \"vocabulary\": {\n",
    "    \"dtype\": \"float: IEEE floating point; int: signed integer; uint: unsigned integer; string: HDF5 string (variable or fixed length). 'sizes' lists the allowed element sizes in bytes.\",\n",
    "    \"dims\": \"One entry per dimension: a number is an exact size; a name is a symbol bound at its first use and equal wherever else it is used in the same group. Symbols of a referenced group are written REF.SYMBOL.\",\n",
    "    \"layout\": \"'chunked': the dataset must use chunked storage.\",\n",
    "    \"attribute\": \"type (string|int), required, value (exact value), one_of (allowed values), equals (a symbol the value must equal), json (the text must be empty or valid JSON), hex (the text must be this many lowercase hex digits).\",\n",
    "    \"references\": \"Named references to other groups: 'link' is a soft link in the group, 'attribute' a string attribute holding the same path; 'kind' is the kind of group that must be found there.\",\n",
    "    \"checks\": \"at_least: symbol >= value. equal: symbols a and b agree (skipped when one is unknown). range: every integer in the dataset (or its column) is >= min and < below. finite: every value is finite. all_equal: every value equals value, when the attribute in 'when' has the given value. mesh_readable: the mesh is accepted by dtx's reader (no face repeating a vertex, content_hash matching the data).\"\n",
    "  },\n",
    "  \"root\": {\n",
    "    \"attributes\": {\n",
    "      \"format\": { \"type\": \"string\", \"required\": true, \"value\": \"dtx\" },\n",
    "      \"format_version\": { \"type\": \"int\", \"required\": true, \"value\": 1 },\n",
    "      \"created_by\": { \"type\": \"string\", \"required\": true }\n",
    "    }\n",
    "  },\n",
    "  \"kinds\": [\n",
    "    {\n",
    "      \"name\": \"meshes\",\n",
    "      \"group\": \"/meshes\",\n",
    "      \"doc\": \"A triangle mesh: rest shapes of sources and targets.\",\n",
    "      \"datasets\": {\n",
    "        \"vertices\": { \"required\": true, \"dtype\": \"float\", \"sizes\": [8], \"dims\": [\"nv\", 3],\n",
    "                      \"doc\": \"vertex positions, row i = x, y, z of vertex i\" },\n",
    "        \"faces\": { \"required\": true, \"dtype\": \"int\", \"sizes\": [4], \"dims\": [\"nf\", 3],\n",
    "                   \"doc\": \"triangles as 0-based vertex indices, counter-clockwise\" }\n",
    "      },\n",
    "      \"attributes\": {\n",
    "        \"source\": { \"type\": \"string\", \"required\": true, \"doc\": \"where the mesh came from, e.g. the OBJ path\" },\n",
    "        \"nv\": { \"type\": \"int\", \"required\": true, \"equals\": \"nv\" },\n",
    "        \"nf\": { \"type\": \"int\", \"required\": true, \"equals\": \"nf\" },\n",
    "        \"content_hash\": { \"type\": \"string\", \"required\": false, \"hex\": 16,\n",
    "                          \"doc\": \"FNV-1a 64 of the little-endian bytes of vertices (f64) then faces (i32)\" }\n",
    "      },\n",
    "      \"references\": {},\n",
    "      \"checks\": [\n",
    "        { \"check\": \"at_least\", \"symbol\": \"nv\", \"value\": 3 },\n",
    "        { \"check\": \"at_least\", \"symbol\": \"nf\", \"value\": 1 },\n",
    "        { \"check\": \"range\", \"dataset\": \"faces\", \"min\": 0, \"below\": \"nv\" },\n",
    "        { \"check\": \"finite\", \"dataset\": \"vertices\" },\n",
    "        { \"check\": \"mesh_readable\" }\n",
    "      ]\n",
    "    },\n",
    "    {\n",
    "      \"name\": \"sequences\",\n",
    "      \"group\": \"/sequences\",\n",
    "      \"doc\": \"An animation: T frames of the vertex positions of a rest mesh.\",\n",
    "      \"datasets\": {\n",
    "        \"positions\": { \"required\": true, \"dtype\": \"float\", \"sizes\": [4, 8], \"dims\": [\"T\", \"nv\", 3],\n",
    "                       \"layout\": \"chunked\", \"doc\": \"frame t, vertex i at [t, i, :]\" },\n",
    "        \"frame_names\": { \"required\": false, \"dtype\": \"string\", \"dims\": [\"T\"],\n",
    "                         \"doc\": \"a name per frame, e.g. the OBJ file it came from\" }\n",
    "      },\n",
    "      \"attributes\": {\n",
    "        \"rest_mesh\": { \"type\": \"string\", \"required\": true },\n",
    "        \"nframes\": { \"type\": \"int\", \"required\": true, \"equals\": \"T\" }\n",
    "      },\n",
    "      \"references\": {\n",
    "        \"rest\": { \"link\": \"rest\", \"attribute\": \"rest_mesh\", \"kind\": \"meshes\", \"required\": true }\n",
    "      },\n",
    "      \"checks\": [\n",
    "        { \"check\": \"at_least\", \"symbol\": \"T\", \"value\": 1 },\n",
    "        { \"check\": \"equal\", \"a\": \"nv\", \"b\": \"rest.nv\" }\n",
    "      ]\n",
    "    },\n",
    "    {\n",
    "      \"name\": \"markers\",\n",
    "      \"group\": \"/markers\",\n",
    "      \"doc\": \"User-given vertex correspondences between a source and a target mesh.\",\n",
    "      \"datasets\": {\n",
    "        \"source_vertex\": { \"required\": true, \"dtype\": \"int\", \"sizes\": [4], \"dims\": [\"m\"] },\n",
    "        \"target_vertex\": { \"required\": true, \"dtype\": \"int\", \"sizes\": [4], \"dims\": [\"m\"] },\n",
    "        \"label\": { \"required\": true, \"dtype\": \"string\", \"dims\": [\"m\"] }\n",
    "      },\n",
    "      \"attributes\": {\n",
    "        \"source_mesh\": { \"type\": \"string\", \"required\": true },\n",
    "        \"target_mesh\": { \"type\": \"string\", \"required\": true },\n",
    "        \"index_base\": { \"type\": \"int\", \"required\": true, \"value\": 0 }\n",
    "      },\n",
    "      \"references\": {\n",
    "        \"source_mesh\": { \"attribute\": \"source_mesh\", \"kind\": \"meshes\", \"required\": false },\n",
    "        \"target_mesh\": { \"attribute\": \"target_mesh\", \"kind\": \"meshes\", \"required\": false }\n",
    "      },\n",
    "      \"checks\": [\n",
    "        { \"check\": \"at_least\", \"symbol\": \"m\", \"value\": 1 },\n",
    "        { \"check\": \"range\", \"dataset\": \"source_vertex\", \"min\": 0, \"below\": \"source_mesh.nv\" },\n",
    "        { \"check\": \"range\", \"dataset\": \"target_vertex\", \"min\": 0, \"below\": \"target_mesh.nv\" }\n",
    "      ]\n",
    "    },\n",
    "    {\n",
    "      \"name\": \"correspondences\",\n",
    "      \"group\": \"/correspondences\",\n",
    "      \"doc\": \"A triangle correspondence between a source and a target mesh (a cache: recomputed when missing).\",\n",
    "      \"datasets\": {\n",
    "        \"pairs\": { \"required\": true, \"dtype\": \"int\", \"sizes\": [4], \"dims\": [\"P\", 2],\n",
    "                   \"doc\": \"source triangle, target triangle\" },\n",
    "        \"deformed_source\": { \"required\": true, \"dtype\": \"float\", \"sizes\": [8], \"dims\": [\"nv_s\", 3],\n",
    "                             \"doc\": \"the source mesh deformed onto the target\" }\n",
    "      },\n",
    "      \"attributes\": {\n",
    "        \"key\": { \"type\": \"string\", \"required\": true, \"doc\": \"hex hash of the inputs\" },\n",
    "        \"source_mesh\": { \"type\": \"string\", \"required\": true },\n",
    "        \"target_mesh\": { \"type\": \"string\", \"required\": true },\n",
    "        \"markers\": { \"type\": \"string\", \"required\": true },\n",
    "        \"parameters\": { \"type\": \"string\", \"required\": true, \"json\": true },\n",
    "        \"dtx_version\": { \"type\": \"string\", \"required\": true }\n",
    "      },\n",
    "      \"references\": {\n",
    "        \"source_mesh\": { \"attribute\": \"source_mesh\", \"kind\": \"meshes\", \"required\": false },\n",
    "        \"target_mesh\": { \"attribute\": \"target_mesh\", \"kind\": \"meshes\", \"required\": false },\n",
    "        \"markers\": { \"attribute\": \"markers\", \"kind\": \"markers\", \"required\": false }\n",
    "      },\n",
    "      \"checks\": [\n",
    "        { \"check\": \"range\", \"dataset\": \"pairs\", \"column\": 0, \"min\": 0, \"below\": \"source_mesh.nf\" },\n",
    "        { \"check\": \"range\", \"dataset\": \"pairs\", \"column\": 1, \"min\": 0, \"below\": \"target_mesh.nf\" },\n",
    "        { \"check\": \"equal\", \"a\": \"nv_s\", \"b\": \"source_mesh.nv\" },\n",
    "        { \"check\": \"finite\", \"dataset\": \"deformed_source\" }\n",
    "      ]\n",
    "    },\n",
    "    {\n",
    "      \"name\": \"results\",\n",
    "      \"group\": \"/results\",\n",
    "      \"doc\": \"A sequence transferred onto a target mesh, with its provenance.\",\n",
    "      \"datasets\": {\n",
    "        \"positions\": { \"required\": true, \"dtype\": \"float\", \"sizes\": [4, 8], \"dims\": [\"T\", \"nv\", 3],\n",
    "                       \"layout\": \"chunked\", \"doc\": \"frame t, vertex i at [t, i, :]; undefined where frame_done is 0\" },\n",
    "        \"residual\": { \"required\": true, \"dtype\": \"float\", \"sizes\": [8], \"dims\": [\"T\"],\n",
    "                      \"doc\": \"per-frame solver residual; NaN until written\" },\n",
    "        \"frame_done\": { \"required\": true, \"dtype\": \"uint\", \"sizes\": [1], \"dims\": [\"T\"],\n",
    "                        \"doc\": \"1 once the frame is written completely\" }\n",
    "      },\n",
    "      \"attributes\": {\n",
    "        \"method\": { \"type\": \"string\", \"required\": true },\n",
    "        \"job\": { \"type\": \"string\", \"required\": true, \"json\": true },\n",
    "        \"parameters\": { \"type\": \"string\", \"required\": true, \"json\": true },\n",
    "        \"dtx_version\": { \"type\": \"string\", \"required\": true },\n",
    "        \"source_sequence\": { \"type\": \"string\", \"required\": true },\n",
    "        \"target_mesh\": { \"type\": \"string\", \"required\": true },\n",
    "        \"correspondence\": { \"type\": \"string\", \"required\": true },\n",
    "        \"complete\": { \"type\": \"int\", \"required\": true, \"one_of\": [0, 1] }\n",
    "      },\n",
    "      \"references\": {\n",
    "        \"target\": { \"link\": \"target\", \"attribute\": \"target_mesh\", \"kind\": \"meshes\", \"required\": true },\n",
    "        \"source_sequence\": { \"attribute\": \"source_sequence\", \"kind\": \"sequences\", \"required\": false },\n",
    "        \"correspondence\": { \"attribute\": \"correspondence\", \"kind\": \"correspondences\", \"required\": false }\n",
    "      },\n",
    "      \"checks\": [\n",
    "        { \"check\": \"at_least\", \"symbol\": \"T\", \"value\": 1 },\n",
    "        { \"check\": \"equal\", \"a\": \"nv\", \"b\": \"target.nv\" },\n",
    "        { \"check\": \"equal\", \"a\": \"T\", \"b\": \"source_sequence.T\" },\n",
    "        { \"check\": \"all_equal\", \"dataset\": \"frame_done\", \"value\": 1,\n",
    "          \"when\": { \"attribute\": \"complete\", \"value\": 1 } }\n",
    "      ]\n",
    "    }\n",
    "  ]\n",
    "}\n",
    NULL
};

char *dtx_h5_layout_json(void)
{
    size_t n = 0, used = 0;
    char *text;
    for (size_t i = 0; lines[i]; i++)
        n += strlen(lines[i]);
    text = malloc(n + 1);
    if (!text)
        return NULL;
    for (size_t i = 0; lines[i]; i++) {
        size_t len = strlen(lines[i]);
        memcpy(text + used, lines[i], len);
        used += len;
    }
    text[used] = '\0';
    return text;
}
