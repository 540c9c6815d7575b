/* rlimits.c - resource limits for sandboxed processes (see rlimits.h). */
#include "service/rlimits.h"

#include <sys/resource.h>

#if defined(__SANITIZE_ADDRESS__)
#define RLIMIT_AS_WORKS 0
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define RLIMIT_AS_WORKS 0
#endif
#endif
#ifndef RLIMIT_AS_WORKS
#define RLIMIT_AS_WORKS 1
#endif

int rlimit_address_space(void)
{
	return RLIMIT_AS_WORKS;
}

void rlimit_set(int resource, uint64_t soft, uint64_t slack)
{
	struct rlimit rl = {(rlim_t)soft, (rlim_t)(soft + slack)};

	if (resource == RLIMIT_AS && !RLIMIT_AS_WORKS)
		return;
	setrlimit(resource, &rl);
}
