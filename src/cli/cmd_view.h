/*
 * cmd_view.h: `dtx view`, the browser workbench: a self-contained HTML page
 * that plays a source sequence and its results side by side, or lets a
 * user pick marker pairs on two meshes by clicking (src/io/html_view.h).
 */
#ifndef DTX_CMD_VIEW_H
#define DTX_CMD_VIEW_H

/* Runs `dtx view` with main's argc/argv (argv[1] == "view").  Returns 0
 * when the page was written, 1 on an error (message on stderr, no page
 * left), 2 on a usage error. */
int dtx_cmd_view(int argc, char **argv);

/* `dtx report FILE.h5 -o REPORT.html`: the player of FILE.h5's results (as
 * `dtx view FILE.h5` without objects shows them) with the report's Markdown
 * text below it, written to out.  Returns the exit status as dtx_cmd_view
 * does. */
int dtx_view_report(const char *input, const char *out, const char *markdown);

#endif /* DTX_CMD_VIEW_H */
