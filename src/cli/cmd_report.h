/*
 * cmd_report.h: `dtx report`, a Markdown page describing a result file:
 * the run's timings (from the run summary written next to it), and for
 * every result its provenance, a contact sheet and its per-frame residuals.
 */
#ifndef DTX_CMD_REPORT_H
#define DTX_CMD_REPORT_H

/* Runs `dtx report` with main's argc/argv (argv[1] == "report").  Writes
 * REPORT.md (default: FILE.h5 with ".h5" replaced by ".report.md") and the
 * pictures into the directory REPORT.md minus ".md" plus "-pictures"
 * (default "FILE.report-pictures/"), each file atomically.  Returns 0 on
 * success, 1 on an error (message on stderr; no report file left), 2 on a
 * usage error. */
int dtx_cmd_report(int argc, char **argv);

#endif /* DTX_CMD_REPORT_H */
