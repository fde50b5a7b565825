/* status.c: names and messages of dtx_status, and checked allocation. */
#include "status.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

const char *dtx_status_name(dtx_status s)
{
    static const char *const names[] = {
#define DTX_STATUS_NAME_(name, desc) #name,
        DTX_STATUS_TABLE(DTX_STATUS_NAME_)
#undef DTX_STATUS_NAME_
    };
    if ((int)s < 0 || s >= DTX_STATUS_COUNT)
        return "DTX_UNKNOWN";
    return names[s];
}

const char *dtx_status_desc(dtx_status s)
{
    static const char *const descs[] = {
#define DTX_STATUS_DESC_(name, desc) desc,
        DTX_STATUS_TABLE(DTX_STATUS_DESC_)
#undef DTX_STATUS_DESC_
    };
    if ((int)s < 0 || s >= DTX_STATUS_COUNT)
        return "unknown status";
    return descs[s];
}

dtx_status dtx_seterr(dtx_error *err, dtx_status code, const char *fmt, ...)
{
    if (err) {
        va_list ap;
        err->code = code;
        va_start(ap, fmt);
        vsnprintf(err->msg, sizeof err->msg, fmt, ap);
        va_end(ap);
    }
    return code;
}

void dtx_error_prefix(dtx_error *err, const char *fmt, ...)
{
    char prefix[512], old[sizeof err->msg];
    va_list ap;
    if (!err)
        return;
    va_start(ap, fmt);
    vsnprintf(prefix, sizeof prefix, fmt, ap);
    va_end(ap);
    memcpy(old, err->msg, sizeof old);
    /* Truncation of an overlong message is acceptable; keep the prefix. */
    {
        size_t n = strlen(prefix);
        if (n > sizeof err->msg - 3)
            n = sizeof err->msg - 3;
        memcpy(err->msg, prefix, n);
        err->msg[n] = ':';
        err->msg[n + 1] = ' ';
        n += 2;
        {
            size_t m = strlen(old);
            if (m > sizeof err->msg - 1 - n)
                m = sizeof err->msg - 1 - n;
            memcpy(err->msg + n, old, m);
            err->msg[n + m] = '\0';
        }
    }
}

void *dtx_alloc(size_t n, size_t size, int zero)
{
    if (n == 0 || size == 0)
        return calloc(1, 1);
    if (n > SIZE_MAX / size)
        return NULL;
    return zero ? calloc(n, size) : malloc(n * size);
}
