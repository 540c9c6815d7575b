/* sandbox.c - `infilld sandbox --as-mb=N --cpu-s=N -- analyze FILE`
 * (internal): applies resource limits to this process, then runs the
 * CLI's analyze.  The HTTP server spawns it for every upload so that
 * reading a hostile mesh can crash or exhaust only this child.
 */
#define _GNU_SOURCE /* prctl */
#include "service/commands.h"
#include "service/rlimits.h"

#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/prctl.h>
#include <sys/resource.h>

int cmd_sandbox(int argc, char **argv)
{
	unsigned long long as_mb = 0, cpu_s = 0;
	int i;

	for (i = 1; i < argc && strcmp(argv[i], "--"); i++) {
		if (!strncmp(argv[i], "--as-mb=", 8))
			as_mb = strtoull(argv[i] + 8, NULL, 10);
		else if (!strncmp(argv[i], "--cpu-s=", 8))
			cpu_s = strtoull(argv[i] + 8, NULL, 10);
		else {
			fprintf(stderr, "infilld sandbox: unknown option %s\n", argv[i]);
			return 2;
		}
	}
	if (i + 1 >= argc || strcmp(argv[i + 1], "analyze") != 0) {
		fprintf(stderr, "infilld sandbox: only 'analyze' runs sandboxed\n");
		return 2;
	}
	prctl(PR_SET_PDEATHSIG, SIGKILL);
	if (as_mb)
		rlimit_set(RLIMIT_AS, as_mb << 20, 0);
	if (cpu_s)
		rlimit_set(RLIMIT_CPU, cpu_s, 0);
	rlimit_set(RLIMIT_CORE, 0, 0);
	rlimit_set(RLIMIT_FSIZE, 0, 0); /* analysis writes no files */
	return cmd_analyze(argc - i - 1, argv + i + 1);
}
