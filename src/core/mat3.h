/*
 * mat3.h: 3x3 rotation tools (mat3.c): the signed SVD, the polar
 * decomposition and the SO(3) log and exp maps.  Matrices are 9 doubles,
 * row-major.  Thread-safe, no allocation.
 */
#ifndef DTX_MAT3_H
#define DTX_MAT3_H

/* Signed SVD A = U diag(sigma) V^T with U, V proper rotations (det +1),
 * sigma[0] >= sigma[1] >= |sigma[2]|; sigma[2] < 0 exactly when det A < 0
 * (the reflection fix folded in).  One-sided Jacobi on A (no A^T A), so
 * small singular values keep their accuracy.  A = 0 gives U = V = I. */
void dtx_svd3(const double A[9], double U[9], double sigma[3], double V[9]);

/* Polar decomposition A = R S with R the rotation nearest to A (maximises
 * tr(R^T A) over SO(3)) and S = R^T A symmetric; S has a negative
 * eigenvalue when det A < 0.  S may be NULL. */
void dtx_polar3(const double A[9], double R[9], double S[9]);

/* Matrix logarithm of a rotation as the axis-angle vector w (R = exp([w]x),
 * |w| = angle in [0, pi]).  Accurate near 0 (series) and near pi (axis from
 * the symmetric part; at exactly pi either of the two valid answers). */
void dtx_so3_log(const double R[9], double w[3]);

/* Rodrigues' formula: the rotation exp([w]x) by angle |w| about w / |w|. */
void dtx_so3_exp(const double w[3], double R[9]);

#endif /* DTX_MAT3_H */
