#pragma once
// One BLAS (and OpenMP) thread for this process and the workers it forks.
//
// MUMPS factors through BLAS, and a multithreaded OpenBLAS sums in an order
// that depends on its thread count, so Ipopt's iterates (and iteration
// counts) would depend on the machine's cores; the parallelism of the
// project is across solves (batch, stress-test, sweeps), never inside one.
// The environment variables are read when the libraries start, so the
// libraries are also told directly, through symbols looked up at run time
// (any BLAS Debian provides works; one without them is left alone).
namespace tensegrity {

// Idempotent and thread-safe; the first call does the work.
void use_one_blas_thread();

// use_one_blas_thread(), then ends the worker threads OpenBLAS starts when it
// loads: each spins on sched_yield for about a tenth of a second before it
// sleeps, a core taken from every short-lived process on a two-core machine.
// For a program's start, before it starts threads of its own (the command
// line): a pool ended while another thread runs BLAS would be unsafe. A later
// multithreaded BLAS call would start the pool again.
void end_blas_thread_pool();

}  // namespace tensegrity
