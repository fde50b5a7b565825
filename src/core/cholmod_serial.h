/*
 * cholmod_serial.h: CHOLMOD's numeric factorisation without its own OpenMP
 * teams (internal to the core library).
 *
 * CHOLMOD's supernodal factorisation runs some of its loops on OpenMP
 * teams of a size fixed when it was built (4 in Debian's), whatever
 * OMP_NUM_THREADS says.  On two cores those teams cost far more than they
 * bring: on the 174,000-unknown correspondence system of the pebble camel
 * (tests/bench/bench_mc.c) a factorisation takes 1.15 s with them and 0.6 s
 * without (2 to 10 s with OMP_THREAD_LIMIT=2); a springs Newton step went
 * from 0.2 s to 7.9 s on a busy machine.  Inside an active parallel region
 * nested regions get one thread (OpenMP's default max-active-levels is 1),
 * so outside one the factorisation is called from the first thread of a
 * team of two while the second waits, and inside one it is called
 * directly.  The loops only copy and clear, so the result is the same bits
 * either way.
 */
#ifndef DTX_CHOLMOD_SERIAL_H
#define DTX_CHOLMOD_SERIAL_H

#include <cholmod.h>

/* cholmod_factorize(A, L, cc) as above; returns its result. */
int dtx__cholmod_factorize_serial(cholmod_sparse *A, cholmod_factor *L, cholmod_common *cc);

#endif /* DTX_CHOLMOD_SERIAL_H */
