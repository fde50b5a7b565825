/*
 * check.h: assertions for the test programs.  They stay on in release
 * builds, print both values on failure, and count failures; a test program
 * ends with `return check_report();`, which prints "N passed, N failed" and
 * returns non-zero when anything failed.
 */
#ifndef DTX_TEST_CHECK_H
#define DTX_TEST_CHECK_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int check_passed_ = 0, check_failed_ = 0;

#define CHECK(cond)                                                                     \
    do {                                                                                \
        if (cond) {                                                                     \
            check_passed_++;                                                            \
        } else {                                                                        \
            check_failed_++;                                                            \
            fprintf(stderr, "%s:%d: CHECK(%s) failed\n", __FILE__, __LINE__, #cond);    \
        }                                                                               \
    } while (0)

#define CHECK_INT(a, op, b)                                                             \
    do {                                                                                \
        long long a_ = (long long)(a), b_ = (long long)(b);                             \
        if (a_ op b_) {                                                                 \
            check_passed_++;                                                            \
        } else {                                                                        \
            check_failed_++;                                                            \
            fprintf(stderr, "%s:%d: CHECK(%s %s %s) failed: %lld vs %lld\n", __FILE__, \
                    __LINE__, #a, #op, #b, a_, b_);                                     \
        }                                                                               \
    } while (0)

#define CHECK_EQ_INT(a, b) CHECK_INT(a, ==, b)

#define CHECK_DBL(a, op, b)                                                             \
    do {                                                                                \
        double a_ = (double)(a), b_ = (double)(b);                                      \
        if (a_ op b_) {                                                                 \
            check_passed_++;                                                            \
        } else {                                                                        \
            check_failed_++;                                                            \
            fprintf(stderr, "%s:%d: CHECK(%s %s %s) failed: %.17g vs %.17g\n",         \
                    __FILE__, __LINE__, #a, #op, #b, a_, b_);                           \
        }                                                                               \
    } while (0)

/* |a - b| <= tol, and neither is NaN. */
#define CHECK_NEAR(a, b, tol)                                                           \
    do {                                                                                \
        double a_ = (double)(a), b_ = (double)(b), t_ = (double)(tol);                  \
        if (fabs(a_ - b_) <= t_) {                                                      \
            check_passed_++;                                                            \
        } else {                                                                        \
            check_failed_++;                                                            \
            fprintf(stderr, "%s:%d: CHECK_NEAR(%s, %s, %s) failed: %.17g vs %.17g "    \
                    "(diff %.3g)\n", __FILE__, __LINE__, #a, #b, #tol, a_, b_,          \
                    fabs(a_ - b_));                                                     \
        }                                                                               \
    } while (0)

/* A status-returning call that must succeed; prints the message if not.
 * errp points at the dtx_error the call fills (never NULL). */
#define CHECK_OK(call, errp)                                                            \
    do {                                                                                \
        const dtx_error *e_ = (errp);                                                   \
        dtx_status s_ = (call);                                                         \
        if (s_ == DTX_OK) {                                                             \
            check_passed_++;                                                            \
        } else {                                                                        \
            check_failed_++;                                                            \
            fprintf(stderr, "%s:%d: %s returned %s: %s\n", __FILE__, __LINE__, #call,   \
                    dtx_status_name(s_), e_->msg);                                      \
        }                                                                               \
    } while (0)

/* Whether s (may be NULL) contains sub; prints both when not.  For use
 * inside CHECK(): CHECK(check_contains(e.msg, "frame 3")). */
static inline int check_contains(const char *s, const char *sub)
{
    int ok = s && strstr(s, sub) != NULL;
    if (!ok)
        fprintf(stderr, "  expected \"%s\" in \"%s\"\n", sub, s ? s : "(null)");
    return ok;
}

static inline int check_report(void)
{
    printf("%d passed, %d failed\n", check_passed_, check_failed_);
    return check_failed_ ? 1 : 0;
}

#endif /* DTX_TEST_CHECK_H */
