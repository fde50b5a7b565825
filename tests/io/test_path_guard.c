/* test_path_guard.c: the input-protection rule (path_guard.h), the path
 * helpers it shares with file_util.h, and the output lock (output_lock.h).
 *   - an output path is refused when it is an input by name, by another
 *     spelling (./, ..), through a hard link or a symbolic link, also when
 *     it does not exist yet and only its directory resolves; a distinct
 *     file is accepted; directories and FIFOs are refused as outputs;
 *   - dtx_file_same_inode finds the same spellings and links, tells two
 *     files apart and says -1 for a missing path; dtx_path_base_name gives
 *     the part after the last '/' ("" after a trailing one);
 *   - dtx_file_replace moves a file to a new name, replaces an existing
 *     file there (whose old contents are gone, not left at the first
 *     name), and fails with both paths named when there is nothing to move;
 *   - the lock is exclusive, names its holder, is released, replaces a
 *     stale lock of a dead pid on this host, refuses one of another host
 *     until break_lock, and is never left half-written. */
#include "check.h"
#include "file_util.h"
#include "output_lock.h"
#include "path_guard.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#define SCRATCH DTX_TEST_SCRATCH

static void write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "w");
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

static int refused(const dtx_path_guard *g, const char *path)
{
    dtx_error e;
    return dtx_path_guard_check(g, path, "the output", &e) != DTX_OK;
}

static void test_guard(void)
{
    char in[512], other[512], hard[512], sym[512], dotted[512], missing[512], sub[512];
    dtx_path_guard g;
    dtx_error e;
    snprintf(in, sizeof in, "%s/in.h5", SCRATCH);
    snprintf(other, sizeof other, "%s/other.h5", SCRATCH);
    snprintf(hard, sizeof hard, "%s/hard.h5", SCRATCH);
    snprintf(sym, sizeof sym, "%s/sym.h5", SCRATCH);
    snprintf(sub, sizeof sub, "%s/sub", SCRATCH);
    snprintf(dotted, sizeof dotted, "%s/sub/../in.h5", SCRATCH);
    snprintf(missing, sizeof missing, "%s/sub/../not-yet.h5", SCRATCH);
    mkdir(sub, 0777);
    write_file(in, "input");
    write_file(other, "other");
    unlink(hard);
    unlink(sym);
    CHECK(link(in, hard) == 0);
    CHECK(symlink(in, sym) == 0);

    /* Same file by device and inode only; a missing path is neither. */
    CHECK_EQ_INT(dtx_file_same_inode(in, dotted), 1);
    CHECK_EQ_INT(dtx_file_same_inode(hard, in), 1);
    CHECK_EQ_INT(dtx_file_same_inode(in, sym), 1);
    CHECK_EQ_INT(dtx_file_same_inode(in, other), 0);
    CHECK_EQ_INT(dtx_file_same_inode(missing, in), -1);
    CHECK_EQ_INT(dtx_file_same_inode(in, missing), -1);

    dtx_path_guard_init(&g);
    CHECK_EQ_INT(dtx_path_guard_add(&g, in, "/source/file", &e), DTX_OK);
    CHECK_EQ_INT(dtx_path_guard_add(&g, NULL, "ignored", &e), DTX_OK);
    CHECK_EQ_INT(g.n, 1);
    CHECK(refused(&g, in));
    CHECK(refused(&g, dotted));
    CHECK(refused(&g, hard));
    CHECK(refused(&g, sym));
    CHECK(!refused(&g, other));
    CHECK(!refused(&g, missing));
    /* The message names the path, its use, the input's role and path. */
    CHECK_EQ_INT(dtx_path_guard_check(&g, sym, "the output", &e), DTX_EINVAL);
    CHECK(strstr(e.msg, "sym.h5 (the output) is also an input (/source/file ") != NULL);
    CHECK(strstr(e.msg, "in.h5)") != NULL);
    dtx_path_guard_free(&g);
    CHECK_EQ_INT(g.n, 0);

    /* An input that does not exist yet is matched by its canonical name. */
    dtx_path_guard_init(&g);
    CHECK_EQ_INT(dtx_path_guard_add(&g, missing, "the job file", &e), DTX_OK);
    {
        char plain[512];
        snprintf(plain, sizeof plain, "%s/not-yet.h5", SCRATCH);
        CHECK(refused(&g, plain));
    }
    CHECK(!refused(&g, in));
    dtx_path_guard_free(&g);

    CHECK_EQ_INT(dtx_path_guard_check_pair(in, "the mesh file", hard, "-o", &e), DTX_EINVAL);
    CHECK_EQ_INT(dtx_path_guard_check_pair(in, "the mesh file", other, "-o", &e), DTX_OK);

    /* Outputs that cannot be replaced by a rename. */
    CHECK_EQ_INT(dtx_output_path_check(sub, "the output", &e), DTX_EINVAL);
    CHECK(strstr(e.msg, "is a directory") != NULL);
    CHECK_EQ_INT(dtx_output_path_check(other, "the output", &e), DTX_OK);
    CHECK_EQ_INT(dtx_output_path_check(missing, "the output", &e), DTX_OK);
    {
        char fifo[512];
        snprintf(fifo, sizeof fifo, "%s/fifo", SCRATCH);
        unlink(fifo);
        if (mkfifo(fifo, 0600) == 0) {
            CHECK_EQ_INT(dtx_output_path_check(fifo, "the output", &e), DTX_EINVAL);
            CHECK(strstr(e.msg, "is a FIFO") != NULL);
        }
    }
}

static void test_base_name(void)
{
    const char *p = "dir/in.h5";
    CHECK(dtx_path_base_name(p) == p + 4);
    CHECK(strcmp(dtx_path_base_name("/meshes/lion"), "lion") == 0);
    CHECK(strcmp(dtx_path_base_name("in.h5"), "in.h5") == 0);
    CHECK(strcmp(dtx_path_base_name("dir/"), "") == 0);
    CHECK(strcmp(dtx_path_base_name(""), "") == 0);
}

/* The whole contents of path into buf (n bytes), "" when unreadable. */
static const char *read_text(const char *path, char *buf, size_t n)
{
    FILE *f = fopen(path, "r");
    size_t k = 0;
    if (f) {
        k = fread(buf, 1, n - 1, f);
        fclose(f);
    }
    buf[k] = '\0';
    return buf;
}

static void test_replace(void)
{
    char from[512], to[512], buf[64];
    dtx_error e;
    int left = -1;
    snprintf(from, sizeof from, "%s/replace.partial", SCRATCH);
    snprintf(to, sizeof to, "%s/replace.h5", SCRATCH);
    unlink(to);
    /* Nothing at the new name yet. */
    write_file(from, "first");
    CHECK_EQ_INT(dtx_file_replace(from, to, &left, &e), DTX_OK);
    CHECK_EQ_INT(left, 0);
    CHECK(strcmp(read_text(to, buf, sizeof buf), "first") == 0);
    CHECK(access(from, F_OK) != 0);
    /* Over an existing file: the new contents in place, the old ones gone
     * (the exchange leaves them at `from` only until they are unlinked). */
    write_file(from, "second");
    CHECK_EQ_INT(dtx_file_replace(from, to, &left, &e), DTX_OK);
    CHECK_EQ_INT(left, 0);
    CHECK(strcmp(read_text(to, buf, sizeof buf), "second") == 0);
    CHECK(access(from, F_OK) != 0);
    /* Nothing to move: an error naming both paths, the target untouched. */
    CHECK_EQ_INT(dtx_file_replace(from, to, &left, &e), DTX_EIO);
    CHECK(strstr(e.msg, from) != NULL && strstr(e.msg, to) != NULL);
    CHECK(strstr(e.msg, "No such file") != NULL);
    CHECK(strcmp(read_text(to, buf, sizeof buf), "second") == 0);
    unlink(to);
}

static void test_lock(void)
{
    char out[512], lockp[512], host[256];
    dtx_output_lock a, b;
    dtx_error e;
    char note[1024];
    pid_t dead;
    FILE *f;
    snprintf(out, sizeof out, "%s/out.h5", SCRATCH);
    snprintf(lockp, sizeof lockp, "%s/out.h5.lock", SCRATCH);
    unlink(lockp);
    gethostname(host, sizeof host);
    host[sizeof host - 1] = '\0';

    CHECK_EQ_INT(dtx_output_lock_acquire(out, 0, &a, note, sizeof note, &e), DTX_OK);
    CHECK(a.path != NULL);
    CHECK_EQ_INT(note[0], '\0');
    /* Held: a second taker is refused, told host and pid. */
    CHECK_EQ_INT(dtx_output_lock_acquire(out, 0, &b, note, sizeof note, &e), DTX_EIO);
    CHECK(b.path == NULL);
    {
        char want[400];
        snprintf(want, sizeof want, "is being written by another dtx run: host %s, pid %ld, started ",
                 host, (long)getpid());
        CHECK(strstr(e.msg, want) != NULL);
        CHECK(strstr(e.msg, "--break-lock") != NULL);
    }
    CHECK_EQ_INT(dtx_output_lock_release(&a), 0);
    CHECK(access(lockp, F_OK) != 0);
    CHECK(a.path == NULL);
    CHECK_EQ_INT(dtx_output_lock_release(&a), 0); /* zeroed: nothing to do */

    /* A lock of a pid that has ended, on this host: replaced, said so. */
    dead = fork();
    if (dead == 0)
        _exit(0);
    waitpid(dead, NULL, 0);
    f = fopen(lockp, "w");
    if (f) {
        fprintf(f, "dtx output lock\nhost: %s\npid: %ld\nstarted: then\n", host, (long)dead);
        fclose(f);
    }
    CHECK_EQ_INT(dtx_output_lock_acquire(out, 0, &a, note, sizeof note, &e), DTX_OK);
    CHECK(strstr(note, "replaced the stale lock") != NULL);
    dtx_output_lock_release(&a);

    /* Another host's lock: refused, kept, until break_lock. */
    f = fopen(lockp, "w");
    if (f) {
        fprintf(f, "dtx output lock\nhost: elsewhere.example\npid: 1\nstarted: earlier\n");
        fclose(f);
    }
    CHECK_EQ_INT(dtx_output_lock_acquire(out, 0, &a, note, sizeof note, &e), DTX_EIO);
    CHECK(strstr(e.msg, "host elsewhere.example, pid 1, started earlier") != NULL);
    CHECK(access(lockp, F_OK) == 0);
    CHECK_EQ_INT(dtx_output_lock_acquire(out, 1, &a, note, sizeof note, &e), DTX_OK);
    CHECK(strstr(note, "removed the lock") != NULL && strstr(note, "elsewhere.example") != NULL);
    dtx_output_lock_release(&a);

    /* A lock without details (damaged): refused, not judged stale. */
    write_file(lockp, "");
    CHECK_EQ_INT(dtx_output_lock_acquire(out, 0, &a, note, sizeof note, &e), DTX_EIO);
    CHECK(strstr(e.msg, "does not say which") != NULL);
    unlink(lockp);

    /* No directory: the system's reason. */
    {
        char nodir[512];
        snprintf(nodir, sizeof nodir, "%s/no-such-dir/out.h5", SCRATCH);
        CHECK_EQ_INT(dtx_output_lock_acquire(nodir, 0, &a, NULL, 0, &e), DTX_EIO);
        CHECK(strstr(e.msg, strerror(ENOENT)) != NULL);
    }
}

int main(void)
{
    test_guard();
    test_base_name();
    test_replace();
    test_lock();
    return check_report();
}
