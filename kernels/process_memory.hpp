#pragma once
// Keep memory a solve frees inside the process, for the next solve to reuse.
//
// A solve allocates and frees work arrays of up to many megabytes (sparse
// patterns, factors, symbolic tables). glibc returns blocks above its mmap
// threshold, and free space above its trim threshold, to the kernel, so each
// solve in a long-running process (batch, stress-test, compare, the server,
// the benchmarks) first-touches its pages again: on a virtual machine those
// page faults cost as much as the symbolic analysis they serve. Programs
// that run many solves call this once at start; the price is that the
// process keeps its peak heap until it exits.
namespace tensegrity {

// Idempotent; a no-op where the C library has no mallopt.
void keep_freed_memory_in_process();

}  // namespace tensegrity
