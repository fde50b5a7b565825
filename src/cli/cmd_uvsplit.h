/*
 * cmd_uvsplit.h: `dtx generate uvsplit`, the one `dtx generate` kind with a
 * file of its own (cmd_generate.c hands it argv).
 */
#ifndef DTX_CMD_UVSPLIT_H
#define DTX_CMD_UVSPLIT_H

/* Runs `dtx generate uvsplit IN OUT.obj [--materials 1|2]` with main's
 * argc/argv (argv[1] == "generate", argv[2] == "uvsplit"): IN split as an
 * export splits it along a cylindrical UV seam and, with 2 materials (the
 * default), where they meet (core/uvsplit.h); OUT.obj gets v, vt, vn,
 * usemtl and an mtllib line naming OUT.mtl, written beside it.  Returns the
 * exit status: 0 on success, 1 on an error (message on stderr), 2 on a
 * usage error. */
int dtx_cmd_generate_uvsplit(int argc, char **argv);

#endif /* DTX_CMD_UVSPLIT_H */
