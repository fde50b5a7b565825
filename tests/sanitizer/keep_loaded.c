/* keep_loaded.c: linked into the sanitizer build's dtx and its test programs
 * only (never into a release build).
 *
 * OpenMPI loads its plugins (mca_*.so, and the libraries they bring) with
 * dlopen and unloads them in MPI_Finalize.  The allocations MPI_Init leaves
 * behind are known and suppressed by module name in tests/lsan.supp, but
 * once a plugin is unloaded LeakSanitizer can no longer name the module a
 * stack frame was in ("<unknown module>").  The only way around that was
 * DWARF unwinding of every malloc (fast_unwind_on_malloc=0), which made each
 * dtx start 0.6 s slower under the sanitizers.  Defined here, in the
 * executable, this dlclose takes the place of the C library's for every
 * library in the process: nothing is ever unloaded, every frame keeps its
 * module, and the fast frame-pointer unwinder can be used. */
int dlclose(void *handle);

int dlclose(void *handle)
{
    (void)handle;
    return 0;
}
