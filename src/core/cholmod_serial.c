/*
 * cholmod_serial.c: CHOLMOD's numeric factorisation without its own OpenMP
 * teams (cholmod_serial.h).
 */
#include "cholmod_serial.h"

#ifdef _OPENMP
#include <omp.h>
#endif

int dtx__cholmod_factorize_serial(cholmod_sparse *A, cholmod_factor *L, cholmod_common *cc)
{
    int ok = 0;
#ifdef _OPENMP
    if (!omp_in_parallel()) {
#pragma omp parallel num_threads(2)
        {
#pragma omp master
            ok = cholmod_factorize(A, L, cc);
        }
        return ok;
    }
#endif
    ok = cholmod_factorize(A, L, cc);
    return ok;
}
