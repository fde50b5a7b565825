/*
 * progress.c: see progress.h.
 */
#include "progress.h"

#include <math.h>
#include <string.h>
#include <unistd.h>

#define BAR_WIDTH 28
#define TTY_PERIOD 0.2

const char *dtx_progress_duration(double seconds, char *buf, size_t n)
{
    long s = seconds > 0 && isfinite(seconds) ? (long)(seconds + 0.5) : 0;
    if (s >= 3600)
        snprintf(buf, n, "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
    else if (s >= 60)
        snprintf(buf, n, "%ld:%02ld", s / 60, s % 60);
    else
        snprintf(buf, n, "%ld s", s);
    return buf;
}

void dtx_progress_start(dtx_progress *p, FILE *out, int tty, double interval, int64_t total,
                        double now)
{
    memset(p, 0, sizeof *p);
    p->out = out;
    p->tty = tty < 0 ? (out && isatty(fileno(out))) : tty;
    p->interval = interval > 0 ? interval : 10.0;
    p->total = total;
    p->t_start = p->t_last = now;
}

/* Frames/s and the remaining time estimate. */
static void rates(const dtx_progress *p, double now, double *fps, double *eta)
{
    double el = now - p->t_start;
    *fps = el > 0 ? (double)p->done / el : 0.0;
    *eta = *fps > 0 ? (double)(p->total - p->done) / *fps : 0.0;
}

static void draw(dtx_progress *p, double now, int final)
{
    double fps, eta, frac = p->total > 0 ? (double)p->done / (double)p->total : 1.0;
    char d[32];
    rates(p, now, &fps, &eta);
    if (p->tty) {
        char bar[BAR_WIDTH + 1];
        int k = (int)(frac * BAR_WIDTH);
        for (int i = 0; i < BAR_WIDTH; i++)
            bar[i] = i < k ? '#' : '.';
        bar[BAR_WIDTH] = '\0';
        fprintf(p->out, "\r\033[Kdtx: [%s] %lld/%lld frames  %.0f frames/s  %s %s", bar,
                (long long)p->done, (long long)p->total, fps, final ? "took" : "ETA",
                dtx_progress_duration(final ? now - p->t_start : eta, d, sizeof d));
        p->drawn = 1;
        if (final) {
            fputc('\n', p->out);
            p->drawn = 0;
        }
    } else {
        fprintf(p->out, "dtx: progress: %lld/%lld frames (%.1f%%), %.0f frames/s, %s %s\n",
                (long long)p->done, (long long)p->total, 100.0 * frac, fps,
                final ? "took" : "ETA",
                dtx_progress_duration(final ? now - p->t_start : eta, d, sizeof d));
    }
    fflush(p->out);
    p->t_last = now;
}

void dtx_progress_update(dtx_progress *p, int64_t done, double now)
{
    if (!p->out)
        return;
    p->done = done;
    if (now - p->t_last >= (p->tty ? TTY_PERIOD : p->interval))
        draw(p, now, 0);
}

void dtx_progress_message(dtx_progress *p, const char *text)
{
    if (!p->out)
        return;
    if (p->drawn) {
        fputs("\r\033[K", p->out);
        p->drawn = 0;
    }
    fprintf(p->out, "%s\n", text);
    fflush(p->out);
}

void dtx_progress_finish(dtx_progress *p, double now)
{
    if (!p->out || p->total == 0)
        return;
    draw(p, now, 1);
}
