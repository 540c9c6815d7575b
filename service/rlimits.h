/* rlimits.h - resource limits of the processes that run untrusted work
 * (the upload sandbox and job processes). */
#ifndef INFILLD_RLIMITS_H
#define INFILLD_RLIMITS_H

#include <stdint.h>

/* Soft limit `soft`, hard limit soft + slack: the slack leaves room for
 * the soft limit's signal (SIGXCPU) to be seen before the kernel's
 * SIGKILL at the hard limit.  RLIMIT_AS is skipped in AddressSanitizer
 * builds (ASan reserves terabytes of shadow address space at start-up,
 * so any address-space limit kills the process before main): those
 * builds cannot enforce memory limits; see rlimit_address_space(). */
void rlimit_set(int resource, uint64_t soft, uint64_t slack);

/* 1 when RLIMIT_AS is enforced by this build, 0 under ASan. */
int rlimit_address_space(void);

#endif
