/* bench_fea.c - the FEA solver on an n^3 grid (default 100^3 = 1M
 * elements): a solid block and a thin-walled lattice (walls 2 voxels
 * thick every 10 voxels in x, y and z and on the outer faces, the rest
 * rho_min: stiffness contrast 1e-9), the default load case (plate fixed, 1000 N down on the
 * top), relative residual 1e-6.  Prints one "key value" per line.
 *
 *   bench_fea [n] [threads] [solid|lattice|open|both] [levels] [smooth] [jacobi_w]
 *
 * open: the lattice without the outer walls, so the top load sits on
 * rho_min voids (a harder, less realistic case).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <time.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/fea/fea.h"

static double now_s(void)
{
	struct timespec ts;

	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static double cpu_s(void)
{
	struct rusage ru;

	getrusage(RUSAGE_SELF, &ru);
	return (double)ru.ru_utime.tv_sec + 1e-6 * (double)ru.ru_utime.tv_usec +
	       (double)ru.ru_stime.tv_sec + 1e-6 * (double)ru.ru_stime.tv_usec;
}

static long peak_rss_mb(void)
{
	struct rusage ru;

	getrusage(RUSAGE_SELF, &ru);
	return ru.ru_maxrss / 1024;
}

static int run(const char *name, int n, int threads, int lattice, int levels, int smooth,
	       double jw)
{
	struct fea_grid g;
	struct fea_loads l;
	struct fea_opts o;
	struct fea_solver *s = NULL;
	struct fea_result r;
	struct err e;
	double t0, t1, t2, c0, c1, c2;

	err_clear(&e);
	memset(&g, 0, sizeof g);
	g.nx = g.ny = g.nz = n;
	g.h_mm = 0.5;
	g.part_hi_mm = (struct vec3){n * 0.5, n * 0.5, n * 0.5};
	g.rho = mem_alloc((size_t)n * n * n * sizeof *g.rho);
	if (!g.rho)
		return 1;
	for (int k = 0; k < n; k++)
		for (int j = 0; j < n; j++)
			for (int i = 0; i < n; i++) {
				int wall = i % 10 < 2 || j % 10 < 2 || k % 10 < 2 ||
					   (lattice == 1 && (i >= n - 2 || j >= n - 2 || k >= n - 2));
				g.rho[((size_t)k * n + j) * n + i] = !lattice || wall ? 1 : 0.001f;
			}
	fea_opts_default(&o);
	o.threads = threads;
	o.levels = levels;
	if (smooth > 0)
		o.smooth = smooth;
	if (jw > 0)
		o.jacobi_w = jw;
	if (fea_loads_default(&l, (struct fea_material){FEA_PLA_E_MPA, FEA_PLA_NU}, &e))
		return 1;
	t0 = now_s();
	c0 = cpu_s();
	if (fea_solver_new(&g, &l, &o, &s, &e)) {
		fprintf(stderr, "%s: %s\n", name, e.msg);
		return 1;
	}
	t1 = now_s();
	c1 = cpu_s();
	if (fea_solve(s, &r, &e)) {
		fprintf(stderr, "%s: %s\n", name, e.msg);
		return 1;
	}
	t2 = now_s();
	c2 = cpu_s();
	printf("%s_elements %zu\n", name, r.elements);
	printf("%s_dofs %zu\n", name, r.dofs);
	printf("%s_levels %d\n", name, r.levels);
	printf("%s_iterations %d\n", name, r.iterations);
	printf("%s_residual %.3g\n", name, r.residual);
	printf("%s_setup_s %.2f\n", name, t1 - t0);
	printf("%s_cg_s %.2f\n", name, t2 - t1);
	printf("%s_total_s %.2f\n", name, t2 - t0);
	printf("%s_setup_cpu_s %.2f\n", name, c1 - c0);
	printf("%s_cg_cpu_s %.2f\n", name, c2 - c1);
	printf("%s_solve_s %.2f\n", name, r.solve_s);
	printf("%s_mem_mb %.0f\n", name, r.mem_bytes / 1e6);
	printf("%s_peak_rss_mb %ld\n", name, peak_rss_mb());
	printf("%s_compliance_nmm %.6g\n", name, r.compliance_nmm);
	printf("%s_max_u_mm %.6g\n", name, r.max_displacement_mm);
	fflush(stdout);
	fea_solver_free(s);
	fea_loads_fini(&l);
	fea_grid_fini(&g);
	return 0;
}

int main(int argc, char **argv)
{
	int n = argc > 1 ? atoi(argv[1]) : 100;
	int threads = argc > 2 ? atoi(argv[2]) : 2;
	const char *mode = argc > 3 ? argv[3] : "both";
	int levels = argc > 4 ? atoi(argv[4]) : 0;
	int smooth = argc > 5 ? atoi(argv[5]) : 0;
	double jw = argc > 6 ? atof(argv[6]) : 0;
	int rc = 0;

	printf("threads %d\nn %d\n", threads, n);
	if (!strcmp(mode, "open"))
		return run("open", n, threads, 2, levels, smooth, jw);
	if (strcmp(mode, "lattice"))
		rc |= run("solid", n, threads, 0, levels, smooth, jw);
	if (strcmp(mode, "solid"))
		rc |= run("lattice", n, threads, 1, levels, smooth, jw);
	return rc;
}
