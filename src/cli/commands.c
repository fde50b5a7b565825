/*
 * commands.c: the table of every `dtx` command: its one-line summary, usage,
 * description, options (each with one line on what it does) and examples.
 * `dtx help`, `dtx COMMAND --help`, the usage printed on a usage error and
 * the check of a command line's options all come from here (options.h), so
 * an option exists for a user exactly when it is listed here.
 */
#include "options.h"

#include <stddef.h>

/* ------------------------------------------------------------------ */
/* import                                                              */
/* ------------------------------------------------------------------ */

static const dtx_cli_opt import_mesh_opts[] = {
    {"-o", "OUT.h5", "the dtx file to add the mesh to (created when missing)"},
    {"--name", "NAME", "the mesh's name: it becomes /meshes/NAME"},
    {"--dataset", "PATH", "take the vertices from one frame of this dataset of an HDF5 input"},
    {"--frame", "N", "which frame of --dataset (0-based; default 0)"},
    {"--axes", "ORDER", "the dataset's axis order in T, V, C (default TVC; DFAUST: VCT)"},
    {"--faces", "[FILE:]PATH", "the (F, 3) integer dataset of 0-based faces (needed with "
                               "--dataset)"},
    {NULL, NULL, NULL},
};

static const dtx_cli_cmd import_mesh = {
    "import mesh",
    "add a rest mesh (OBJ, PLY, OFF, glTF 2.0 or FBX) to a dtx file",
    "dtx import mesh FILE.(obj|ply|off|glb|gltf|fbx) -o OUT.h5 --name NAME\n"
    "dtx import mesh FILE.h5 --dataset PATH --faces [FILE:]PATH [--axes ORDER] [--frame N]\n"
    "                -o OUT.h5 --name NAME",
    "Reads the mesh, checks it (indices, finite coordinates, degenerate faces) and\n"
    "stores it as /meshes/NAME with its UVs, normals, materials (OBJ usemtl/mtllib,\n"
    "glTF, FBX) or vertex colours (PLY), in the file's own vertex order.  Polygons are\n"
    "fan-triangulated with a warning.\n"
    "UVs, normals and materials (OBJ vt/vn/usemtl/mtllib, PLY vertex colours,\n"
    "normals and s/t; glTF/FBX through assimp, in the file's vertex order) are\n"
    "stored with it.\n"
    "A failed import leaves a new file removed and an existing file as it was.\n"
    "From an HDF5 file other programs wrote (DFAUST's registrations, say), one frame\n"
    "of a positions dataset (any axis order, --axes) with a faces dataset.",
    import_mesh_opts,
    "dtx import mesh cat-reference.obj -o cat-lion.h5 --name cat\n"
    "dtx import mesh registrations_f.hdf5 --dataset /50004_jiggle_on_toes --axes VCT \\\n"
    "    --faces /faces -o in.h5 --name 50004",
    2,
};

static const dtx_cli_opt import_sequence_opts[] = {
    {"-o", "OUT.h5", "the dtx file to add the sequence to (created when missing)"},
    {"--name", "NAME", "the sequence's name: it becomes /sequences/NAME"},
    {"--mesh", "/meshes/MESH", "the rest mesh every frame must match (vertex count and faces)"},
    {"--dtype", "float32|float64", "how positions are stored (default float32)"},
    {"--compress", "none|gzip", "compression of the positions (default none: gzip saves ~1.4:1)"},
    {"--fps", "F", "the sequence's frame rate, stored and used by every export (default: none "
                   "stored, exports assume 24)"},
    {"--glob", "PATTERN", "take only the files whose name matches (shell pattern, e.g. 'pose-*.obj')"},
    {"--exclude", "PATTERN", "leave out the files whose name matches (repeatable)"},
    {"--dataset", "PATH", "read the frames from this dataset of an HDF5 input; a wildcard in "
                          "the last part ('/*') imports every matching dataset, each named "
                          "after it"},
    {"--axes", "ORDER", "the dataset's axis order in T (frames), V (vertices), C (x, y, z): "
                        "TVC (default), VCT for DFAUST; VC for one frame"},
    {"--faces", "[FILE:]PATH", "an integer (F, 3) dataset of 0-based faces (in the input, or "
                               "in FILE) that must equal the rest mesh's; left out of a "
                               "wildcard"},
    {NULL, NULL, NULL},
};

static const dtx_cli_cmd import_sequence = {
    "import sequence",
    "add an animation (mesh files, a .npy, PC2 or MDD file, HDF5 datasets)",
    "dtx import sequence (DIR | FILE...) -o OUT.h5 --name NAME --mesh /meshes/MESH\n"
    "                    [--dtype float32|float64] [--compress none|gzip] [--fps F]\n"
    "                    [--glob PATTERN] [--exclude PATTERN]...\n"
    "dtx import sequence FILE.(npy|pc2|mdd) -o OUT.h5 --name NAME --mesh /meshes/MESH ...\n"
    "dtx import sequence FILE.h5 --dataset PATH [--axes ORDER] [--faces [FILE:]PATH]\n"
    "                    -o OUT.h5 (--name NAME | --dataset with a wildcard) --mesh /meshes/MESH ...",
    "A folder's mesh files are taken in natural order (cat-2 before cat-10).  Every\n"
    "frame must have the rest mesh's vertex count and faces; a frame identical to the\n"
    "rest mesh (a reference pose in the folder) gets a warning.  Frame file names are\n"
    "stored (dtx inspect lists them).\n"
    "A .npy array (T, V, 3) or (V, 3) of float32 or float64, a PC2 or an MDD point\n"
    "cache gives the positions of the rest mesh's vertices, in its vertex order.  An\n"
    "HDF5 dataset may have any axis order (--axes); --dataset '/*' imports every\n"
    "dataset of the root group but the --faces one, as /sequences/DATASET_NAME.",
    import_sequence_opts,
    "dtx import sequence poses/ -o cat-lion.h5 --name cat-poses --mesh /meshes/cat\n"
    "dtx import sequence gallop/ --exclude '*reference*' -o horse.h5 --name gallop --mesh /meshes/horse --fps 30\n"
    "dtx import sequence walk.npy -o in.h5 --name walk --mesh /meshes/body\n"
    "dtx import sequence registrations_f.hdf5 --dataset '/50004_*' --axes VCT --faces /faces \\\n"
    "    -o in.h5 --mesh /meshes/50004",
    2,
};

static const dtx_cli_opt import_markers_opts[] = {
    {"-o", "OUT.h5", "the dtx file to add the markers to (created when missing)"},
    {"--name", "NAME", "the marker set's name: it becomes /markers/NAME"},
    {"--index-base", "0|1", "whether the CSV's vertex indices start at 0 or 1 (or a line "
                            "'# index_base: 0' in the file)"},
    {"--source", "/meshes/A", "check the source indices against this mesh now"},
    {"--target", "/meshes/B", "check the target indices against this mesh now"},
    {NULL, NULL, NULL},
};

static const dtx_cli_cmd import_markers = {
    "import markers",
    "add source/target marker pairs from a CSV file",
    "dtx import markers FILE.csv [--index-base 0|1] -o OUT.h5 --name NAME\n"
    "                   [--source /meshes/A] [--target /meshes/B]",
    "The CSV has rows source_vertex,target_vertex[,label].  The index base is always\n"
    "explicit: --index-base or a '# index_base: N' line in the file (both: they must agree).",
    import_markers_opts,
    "dtx import markers markers.csv --index-base 0 -o cat-lion.h5 --name cat-lion \\\n"
    "    --source /meshes/cat --target /meshes/lion",
    2,
};

/* ------------------------------------------------------------------ */
/* run, keypoints                                                      */
/* ------------------------------------------------------------------ */

static const dtx_cli_opt run_opts[] = {
    {"--resume", NULL, "continue the interrupted run of the same job (OUTPUT.partial)"},
    {"--break-lock", NULL, "take over OUTPUT.lock left by a run that is gone (say, on another "
                           "host); check first that it is"},
    {"--quiet", NULL, "print errors only (no progress, no warnings)"},
    {"--summary", "FILE.json", "where to write the run summary (default OUTPUT.summary.json)"},
    {"--store", "DIR", "correspondence store shared by jobs: take each target's correspondence "
                       "from DIR/KEY.h5, or compute and write it there (overrides the job's "
                       "correspondence_store)"},
    {"--correspond-only", NULL, "compute the correspondences into the store and stop (no "
                                "transfer; the output is not touched)"},
    {NULL, NULL, NULL},
};

static const dtx_cli_cmd run = {
    "run",
    "run a transfer job (alone or under mpirun)",
    "dtx run JOB.json [--resume] [--break-lock] [--quiet] [--summary FILE.json]\n"
    "        [--store DIR] [--correspond-only]",
    "Reads the job (schemas/job.schema.json), computes or reuses each target's\n"
    "correspondence, transfers every frame of every sequence onto every target and\n"
    "writes OUTPUT (through OUTPUT.partial, renamed only when complete).  OUTPUT.lock\n"
    "keeps a second run off the same output; dtx never writes over its inputs.",
    run_opts,
    "mpirun -np 2 dtx run jobs/cat-lion.json\n"
    "dtx run job.json --resume",
    1,
};

static const dtx_cli_opt keypoints_opts[] = {
    {"--mesh", "/meshes/SRC", "the source rest mesh"},
    {"--sequence", "/sequences/S", "a source sequence to learn from (repeatable)"},
    {"--markers", "/markers/M", "markers that label the key points and start the correspondence"},
    {"--target", "/meshes/T", "also map the key points onto this target (needs --markers)"},
    {"--name", "NAME", "the key-point set's name (default: the mesh's name)"},
    {"-o", "OUT.h5", "where to write /keypoints/NAME (default: FILE.h5 itself)"},
    {"--candidates", "N", "candidate vertices evaluated (1..100000)"},
    {"--eps", "E", "stop adding key points once the fit error is at most E (>= 0)"},
    {"--max", "K", "most key points chosen (1..10000)"},
    {"--training-frames", "N", "frames sampled from the sequences for the fit (default 32)"},
    {"--csv", "OUT.csv", "also write the key points (and target partners) as a marker CSV"},
    {NULL, NULL, NULL},
};

static const dtx_cli_cmd keypoints = {
    "keypoints",
    "choose key points of a source animation (biharmonic method)",
    "dtx keypoints FILE.h5 --mesh /meshes/SRC --sequence /sequences/S [--sequence ...]\n"
    "              [--markers /markers/M [--target /meshes/T]] [--name NAME] [-o OUT.h5]\n"
    "              [--candidates N] [--eps E] [--max K] [--training-frames N]\n"
    "              [--csv OUT.csv]   (alone or under mpirun)",
    "Automatic key points (Yang et al. 2018): the vertices whose motion best\n"
    "explains the animation through bounded biharmonic weights.",
    keypoints_opts,
    "dtx keypoints cat-lion.h5 --mesh /meshes/cat --sequence /sequences/cat-poses --max 20",
    1,
};

/* ------------------------------------------------------------------ */
/* export, inspect, validate, diff                                     */
/* ------------------------------------------------------------------ */

static const dtx_cli_opt export_opts[] = {
    {"--obj-dir", "DIR", "one OBJ per exported frame, DIR/<name>-NNNNN.obj (1-based)"},
    {"--obj-rest", "REST.obj", "the mesh as OBJ (what a PC2 or MDD cache is applied to)"},
    {"--pc2", "OUT.pc2", "a PC2 point cache, one sample per exported frame"},
    {"--start-frame", "F", "the PC2's start frame (default 0: sample k plays at frame k)"},
    {"--mdd", "OUT.mdd", "an MDD point cache, the same samples with their times in seconds"},
    {"--glb", "OUT.glb", "glTF 2.0 binary: the mesh, the frames as morph targets, an animation"},
    {"--step", NULL, "glb: step between frames instead of interpolating"},
    {"--max-frames", "N", "glb: refuse more frames than N (default and most: 65535)"},
    {"--stride", "K", "export frames 0, K, 2K, ... (default 1)"},
    {"--fps", "F", "frames per second for glb and MDD times (default: the stored rate, else 24)"},
    {NULL, NULL, NULL},
};

static const dtx_cli_cmd export_ = {
    "export",
    "write a result or sequence as OBJ frames, PC2, MDD or glb",
    "dtx export FILE.h5 (/results/TARGET/SEQUENCE | /sequences/SEQUENCE) [--stride K]\n"
    "           [--obj-dir DIR] [--obj-rest REST.obj] [--pc2 OUT.pc2 [--start-frame F]]\n"
    "           [--mdd OUT.mdd] [--glb OUT.glb [--step] [--max-frames N]] [--fps F]",
    "Every file is written atomically; a result must have all its frames.  The README\n"
    "section \"Using results in Blender\" shows how each file plays there.",
    export_opts,
    "dtx export out.h5 /results/lion/cat-poses --obj-rest lion.obj --pc2 lion.pc2 --mdd lion.mdd\n"
    "dtx export out.h5 /results/lion/cat-poses --glb lion.glb --fps 30",
    1,
};

static const dtx_cli_opt inspect_opts[] = {
    {"--json", NULL, "print the same as JSON (with every frame file name)"},
    {"--frames", NULL, "list every frame file name of each sequence (default: the first and last)"},
    {NULL, NULL, NULL},
};

static const dtx_cli_cmd inspect = {
    "inspect",
    "list what a dtx file holds",
    "dtx inspect FILE.h5 [--json] [--frames]",
    "Meshes, sequences, markers, correspondences and results with their provenance,\n"
    "and the run's timings when FILE.h5.summary.json is next to it.  Writes nothing.",
    inspect_opts,
    "dtx inspect build/demo/cat-lion-result.h5",
    1,
};

static const dtx_cli_opt no_opts[] = {{NULL, NULL, NULL}};

static const dtx_cli_cmd validate = {
    "validate",
    "check a dtx file against the layout (schemas/hdf5-layout-v1.md)",
    "dtx validate FILE.h5",
    "Checks every object's shapes, types, index ranges and flags, and that the\n"
    "frames marked done hold finite positions.  Exit 1 with every problem listed.",
    no_opts,
    "dtx validate build/demo/cat-lion-result.h5",
    1,
};

static const dtx_cli_opt diff_opts[] = {
    {"--tol", "REL", "largest difference allowed, relative to the largest coordinate "
                     "(default 1e-12)"},
    {NULL, NULL, NULL},
};

static const dtx_cli_cmd diff = {
    "diff",
    "compare one result in two files (exit 1 if they differ)",
    "dtx diff A.h5 B.h5 /results/TARGET/SEQUENCE [--tol REL]",
    NULL,
    diff_opts,
    "dtx diff a.h5 b.h5 /results/lion/cat-poses --tol 0",
    1,
};

/* ------------------------------------------------------------------ */
/* render, report, generate, version                                   */
/* ------------------------------------------------------------------ */

static const dtx_cli_opt render_opts[] = {
    {"-o", "OUT.png", "the picture to write"},
    {"--frames", "0,4,8", "the frames to draw (0-based)"},
    {"--count", "N", "draw N frames spread over the sequence (default 10)"},
    {"--cols", "C", "panels per row"},
    {"--width", "W", "panel width in pixels"},
    {"--height", "H", "panel height in pixels"},
    {"--view", "side|front|back|top|AZ,EL", "camera direction (default 55,15 degrees)"},
    {"--up", "x|y|z", "the mesh's up axis (default y)"},
    {"--flat", NULL, "flat shading instead of smooth"},
    {"--color", "component|RRGGBB", "colour per connected component, or one colour"},
    {"--supersample", "1..4", "antialiasing factor"},
    {"--no-source", NULL, "a result without the source row above it"},
    {"--no-labels", NULL, "no frame numbers on the panels"},
    {NULL, NULL, NULL},
};

static const dtx_cli_cmd render = {
    "render",
    "draw a mesh, sequence or result as a PNG contact sheet",
    "dtx render (FILE.h5 [/results/T/S | /sequences/S | /meshes/M] | MESH.(obj|ply|off))\n"
    "           -o OUT.png [--frames 0,4,8 | --count N] [--cols C] [--width W] [--height H]\n"
    "           [--view side|front|back|top|AZ,EL] [--up x|y|z] [--flat]\n"
    "           [--color component|RRGGBB] [--supersample 1..4] [--no-source] [--no-labels]",
    "A result is drawn with its source sequence's frames in a row above it.",
    render_opts,
    "dtx render out.h5 /results/lion/cat-poses -o sheet.png --count 5",
    1,
};

static const dtx_cli_opt report_opts[] = {
    {"-o", "REPORT.md", "the page to write (default FILE.report.md, pictures in FILE.report-pictures/); "
                        "REPORT.html: a browser page with the results' player (dtx view) instead of pictures"},
    {"--summary", "FILE.json", "the run summary to read (default FILE.h5.summary.json)"},
    {"--count", "N", "frames per contact sheet (1..1024)"},
    {"--no-pictures", NULL, "no contact sheets"},
    {NULL, NULL, NULL},
};

static const dtx_cli_cmd report = {
    "report",
    "write a Markdown page on a run: phases, speed, results, residuals, pictures",
    "dtx report FILE.h5 [-o REPORT.md] [--summary FILE.json] [--count N] [--no-pictures]",
    "Reads the run summary that dtx run leaves next to its output for the phases\n"
    "and speed; every result gets its provenance, a contact sheet and its residuals.",
    report_opts,
    "dtx report build/demo/cat-lion-result.h5",
    1,
};

static const dtx_cli_opt generate_opts[] = {
    {"--pieces", "N", "pebbles: number of pieces"},
    {"--thickness", "T", "pebbles: thickness of each piece"},
    {"--subdivide", "L", "pebbles: subdivision levels first"},
    {"--gap", "G", "pebbles, eyes: gap between pieces"},
    {"--axis", "x|y|z", "garment, reshape: the up axis"},
    {"--lo", "LO", "garment: lower bound, reshape: top of the legs (fractions of the extent on --axis)"},
    {"--hi", "HI", "garment: upper bound (fraction of the extent on --axis)"},
    {"--offset", "D", "garment: distance of the shell off the body"},
    {"--thicken", "S", "reshape: thickening factor"},
    {"--legs", "L", "reshape: leg lengthening factor"},
    {"--anchors", "I,J,...", "eyes: 0-based vertices the eyes sit at"},
    {"--radius", "R", "eyes: eye radius"},
    {"--levels", "L", "subdivide: midpoint subdivision levels (each splits every triangle in 4)"},
    {"--map", "MAP.csv", "also write generated_vertex,original_vertex rows"},
    {"--markers", "IN.csv", "a marker file to rewrite for the new mesh"},
    {"--index-base", "0|1", "the index base of --markers"},
    {"--markers-out", "OUT.csv", "where to write the rewritten markers"},
    {"--materials", "1|2", "uvsplit: 2 also splits the mesh where two materials meet (default 2)"},
    {NULL, NULL, NULL},
};

static const dtx_cli_cmd generate = {
    "generate",
    "make test targets from a mesh: pebbles, garment, eyes, reshape, subdivide, uvsplit",
    "dtx generate pebbles IN OUT.obj --pieces N [--gap G] [--thickness T] [--subdivide L]\n"
    "dtx generate garment IN OUT.obj --axis x|y|z --lo LO --hi HI [--offset D]\n"
    "dtx generate eyes IN OUT.obj --anchors I,J,... [--radius R] [--gap G]\n"
    "dtx generate reshape IN OUT.obj --axis x|y|z [--thicken S] [--legs L] [--lo LO]\n"
    "dtx generate subdivide IN OUT.obj --levels L   (the input's vertices keep their indices)\n"
    "dtx generate uvsplit IN OUT.obj [--materials 1|2]   (OBJ with vt/vn/usemtl and a .mtl)\n"
    "    pebbles, garment, eyes, reshape and subdivide also [--map MAP.csv] [--markers IN.csv --index-base 0|1 --markers-out OUT.csv]",
    NULL,
    generate_opts,
    "dtx generate pebbles lion.obj pebble-lion.obj --pieces 240",
    1,
};

static const dtx_cli_opt view_opts[] = {
    {"-o", "PAGE.html", "the page to write (one self-contained HTML file)"},
    {"--pick", "/meshes/SRC /meshes/TGT", "pick marker pairs on these two meshes instead of playing"},
    {"--markers", "/markers/M", "show these markers (or OTHER.h5:/markers/M); with --pick: start from them"},
    {"--keypoints", "/keypoints/K", "show these key points on the sequences; --pick: offer them as sources (default: those of SRC)"},
    {"--max-frames", "N", "frame budget: at most N frames in the page, strided to fit (default 300)"},
    {"--stride", "K", "embed frames 0, K, 2K, ... (default: the smallest that fits the budget)"},
    {NULL, NULL, NULL},
};

static const dtx_cli_cmd view = {
    "view",
    "write a browser page: play results beside their source, or pick markers by clicking",
    "dtx view FILE.h5 [OBJECT...] -o PAGE.html [--markers /markers/M] [--keypoints /keypoints/K]\n"
    "         [--max-frames N] [--stride K]\n"
    "dtx view FILE.h5 --pick /meshes/SRC /meshes/TGT -o PAGE.html [--markers /markers/M]\n"
    "         [--keypoints /keypoints/K]",
    "One HTML file that works opened from disk, with no server and no network.\n"
    "OBJECTs are /results/T/S, /sequences/S or /meshes/M, or OTHER.h5:PATH; without\n"
    "them every result of FILE.h5 is shown after the source sequence it was made\n"
    "from.  With --pick, click a point on the source, then on the target, to make a\n"
    "pair; \"Download CSV\" writes a file for `dtx import markers`.",
    view_opts,
    "dtx view out.h5 -o out.html\n"
    "dtx view out.h5 /results/lion/cat-poses cl.h5:/sequences/cat-poses -o out.html\n"
    "dtx view cl.h5 --pick /meshes/cat /meshes/lion --markers /markers/cat-lion -o pick.html",
    1,
};

static const dtx_cli_cmd rm = {
    "rm",
    "remove objects (meshes, sequences, markers, results, ...) from a dtx file",
    "dtx rm FILE.h5 PATH...",
    "Removes every PATH (/meshes/NAME, /sequences/NAME, /markers/NAME, /keypoints/NAME,\n"
    "/correspondences/NAME, /results/TARGET/SEQUENCE or all of /results/TARGET), or\n"
    "none of them: an object that something left in the file refers to (a sequence's\n"
    "rest mesh, a result's target) is refused, naming the referrer.  HDF5 keeps the\n"
    "freed space for later objects of the same file; `h5repack FILE.h5 NEW.h5` writes\n"
    "a compact copy.",
    no_opts,
    "dtx rm cat-lion.h5 /sequences/cat-poses\n"
    "dtx import mesh lion-v2.obj -o cat-lion.h5 --name lion   # after: dtx rm cat-lion.h5 /meshes/lion",
    1,
};

static const dtx_cli_cmd version = {
    "version", "print the version", "dtx version", NULL, no_opts, "dtx --version", 1,
};

static const dtx_cli_cmd help = {
    "help",
    "describe the commands, or one command and its options",
    "dtx help [COMMAND]",
    NULL,
    no_opts,
    "dtx help export\ndtx help import sequence",
    1,
};

static const dtx_cli_cmd *const commands[] = {
    &import_mesh, &import_sequence, &import_markers, &run,      &keypoints,
    &export_,     &inspect,         &validate,       &diff,     &render,
    &report,      &view,            &generate,       &rm,             &version,        &help,     NULL,
};

const dtx_cli_cmd *const *dtx_cli_commands(void)
{
    return commands;
}
