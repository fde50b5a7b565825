/*
 * progress.h: the progress display of a run (rank 0 only, on stderr).
 *
 * On a terminal: one live line redrawn in place (bar, frames done/total,
 * frames/s, ETA), at most five times a second.  Otherwise (a log file, a
 * batch system): a plain line every `interval` seconds.  Nothing at all when
 * the run is quiet.  Not thread-safe; call from the driver's main thread.
 */
#ifndef DTX_PROGRESS_H
#define DTX_PROGRESS_H

#include <stdint.h>
#include <stdio.h>

typedef struct {
    FILE *out;          /* NULL: quiet */
    int tty;            /* live line instead of periodic lines */
    double interval;    /* seconds between plain lines */
    int64_t total;      /* frames to do in this run */
    int64_t done;
    double t_start, t_last;
    int drawn;          /* a live line is on screen */
} dtx_progress;

/* Starts the display of `total` frames at time now (seconds, any epoch).
 * out == NULL makes every call a no-op.  tty < 0 asks isatty(out). */
void dtx_progress_start(dtx_progress *p, FILE *out, int tty, double interval, int64_t total,
                        double now);

/* Records that `done` frames (cumulative) are finished at time now; redraws
 * when due. */
void dtx_progress_update(dtx_progress *p, int64_t done, double now);

/* Prints a line of text without garbling the live line (clears it first). */
void dtx_progress_message(dtx_progress *p, const char *text);

/* Final state: ends the live line (or prints a last plain line). */
void dtx_progress_finish(dtx_progress *p, double now);

/* "1:02:03" / "2:03" / "7 s" for a duration in seconds into buf[n]. */
const char *dtx_progress_duration(double seconds, char *buf, size_t n);

#endif /* DTX_PROGRESS_H */
