/* bench_lattice.c - lattice benchmarks driven by tests/bench/lattice.sh.
 *
 *   bench_lattice gen  MESH UP HEIGHT_MM DENSITY MIN_R_MM OUT.lat [THREADS]
 *       paper pipeline (TetGen, SO, PO, matching) -> binary lattice file
 *   bench_lattice grid MESH UP HEIGHT_MM STRUTS OUT.lat [THREADS]
 *       streaming Freudenthal lattice of about STRUTS struts -> binary file
 *   bench_lattice slice FILE.lat W H LAYERS [THREADS] [AA]
 *       stream the file and render LAYERS planes over its height into a
 *       W x H image fitted to its footprint
 * Each prints `key value` lines (seconds, counts, peak RSS in MB).
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/progress.h"
#include "engine/lattice/density.h"
#include "engine/lattice/generate.h"
#include "engine/lattice/gridgen.h"
#include "engine/lattice/lattice.h"
#include "engine/lattice/slicer.h"
#include "engine/lattice/strut.h"
#include "engine/mesh/mesh.h"

static double peak_rss_mb(void)
{
	struct rusage ru;
	getrusage(RUSAGE_SELF, &ru);
	return ru.ru_maxrss / 1024.0;
}

static int up_of(const char *s)
{
	static const char *names[] = {"z", "-z", "y", "-y", "x", "-x"};
	for (int i = 0; i < 6; i++)
		if (!strcmp(s, names[i]))
			return i;
	return 0;
}

static struct mesh *load(const char *path, const char *up, double height, struct err *e)
{
	struct mesh *m = NULL;
	struct mesh_report r;
	struct mesh_placement pl = {MESH_UNITS_MM, 1, height, up_of(up), 60, 60};

	if (mesh_read_file(path, MESH_FMT_AUTO, &m, NULL, e) || mesh_repair(m, &r, e) ||
	    mesh_place(m, &pl, e)) {
		mesh_free(m);
		return NULL;
	}
	return m;
}

static int dom_inside(void *ctx, struct vec3 p)
{
	return mesh_bvh_inside(ctx, p);
}

static double dom_distance(void *ctx, struct vec3 p)
{
	return mesh_bvh_closest(ctx, p, NULL, NULL);
}

static int cmd_gen(int argc, char **argv)
{
	struct err e;
	struct mesh *m;
	struct lattice *q = NULL;
	struct lattice_density den;
	struct lattice_gen_opts o;
	struct lattice_gen_report r;
	struct box3 b = box3_empty();
	double t0 = progress_now_s();

	if (argc < 8)
		return 2;
	if (!(m = load(argv[2], argv[3], atof(argv[4]), &e))) {
		fprintf(stderr, "gen: %s\n", e.msg);
		return 1;
	}
	for (size_t i = 0; i < m->nv; i++)
		box3_add(&b, m->v[i]);
	lattice_density_constant(&den, b, atof(argv[5]));
	memset(&o, 0, sizeof o);
	o.density = &den;
	o.min_radius_mm = atof(argv[6]);
	o.so_k = 1.6;
	o.po = 1;
	o.po_rounds = 100;
	o.match = 1;
	o.max_subdiv = 2;
	o.mc_samples = 1000;
	o.match_passes = 4;
	o.support_factor = 1.5;
	o.alpha_rad = M_PI / 4;
	o.raw_baseline = 0;
	o.max_nodes = 5000000;
	o.seed = 1;
	o.threads = argc > 8 ? atoi(argv[8]) : 2;
	if (lattice_generate(m, &o, &q, &r, &e) || lattice_write_binary(q, argv[7], &e)) {
		fprintf(stderr, "gen: %s\n", e.msg);
		return 1;
	}
	printf("gen_nodes %zu\ngen_struts %zu\ngen_seconds %.2f\ngen_density_error_mean %.4f\n"
	       "gen_density_error_max %.4f\ngen_voxels %zu\ngen_gamma_so_po %.4f\n"
	       "gen_seconds_stages sample %.2f tetgen %.2f po %.2f match %.2f measure %.2f\n"
	       "gen_rss_mb %.1f\n",
	       q->nnodes, q->nedges, progress_now_s() - t0, r.density_error_mean,
	       r.density_error_max, r.voxels, r.gamma_so_po, r.s_sample, r.s_tetgen, r.s_po,
	       r.s_match, r.s_measure, peak_rss_mb());
	lattice_free(q);
	mesh_free(m);
	return 0;
}

static int cmd_grid(int argc, char **argv)
{
	struct err e;
	struct mesh *m;
	struct mesh_bvh *bvh = NULL;
	struct mesh_report rep;
	struct lattice_domain d;
	struct lattice_grid_opts o;
	struct lattice_grid_stats st;
	double t0 = progress_now_s(), h;

	if (argc < 7)
		return 2;
	if (!(m = load(argv[2], argv[3], atof(argv[4]), &e)) || mesh_analyze(m, &rep, &e) ||
	    mesh_bvh_new(m, &bvh, &e)) {
		fprintf(stderr, "grid: %s\n", e.msg);
		return 1;
	}
	memset(&d, 0, sizeof d);
	d.box = rep.bbox;
	d.inside = dom_inside;
	d.distance = dom_distance;
	d.ctx = bvh;
	d.surface = m;
	d.threads = argc > 7 ? atoi(argv[7]) : 2;
	h = lattice_grid_spacing_for(rep.volume_mm3, atof(argv[5]), 1.6);
	o.spacing_mm = h;
	o.so_k = 1.6;
	o.jitter = 0.15;
	o.r_center_mm = 0.2 * h;
	o.r_rim_mm = 0.12 * h;
	o.support_mm = 0;
	o.seed = 1;
	if (lattice_grid_write(&d, &o, argv[6], &st, &e)) {
		fprintf(stderr, "grid: %s\n", e.msg);
		return 1;
	}
	printf("grid_spacing_mm %.4f\ngrid_nodes %llu\ngrid_struts %llu\ngrid_cells %zu\n"
	       "grid_seconds %.2f\ngrid_rss_mb %.1f\n",
	       h, (unsigned long long)st.nodes, (unsigned long long)st.struts, st.cells,
	       progress_now_s() - t0, peak_rss_mb());
	mesh_bvh_free(bvh);
	mesh_free(m);
	return 0;
}

static int cmd_slice(int argc, char **argv)
{
	struct err e;
	struct lattice_stream *st = NULL;
	struct lattice_file_header h;
	struct lattice_slicer *sl = NULL;
	struct lattice_slicer_opts so;
	struct lattice_slicer_stats ss;
	struct raster *r;
	struct raster_map map;
	int w, hh, layers, threads;
	double t_render = 0, t0 = progress_now_s(), pitch, area = 0;
	struct vec3 sz;

	if (argc < 6)
		return 2;
	w = atoi(argv[3]);
	hh = atoi(argv[4]);
	layers = atoi(argv[5]);
	threads = argc > 6 ? atoi(argv[6]) : 2;
	if (lattice_stream_open(argv[2], &h, &st, &e)) {
		fprintf(stderr, "slice: %s\n", e.msg);
		return 1;
	}
	so.support_mm = h.support_mm > 0 ? h.support_mm : 1.5 * h.max_radius_mm;
	so.threads = threads;
	so.antialias = argc > 7 ? atoi(argv[7]) : 0;
	sz = box3_size(h.bbox);
	/* square pixels, the footprint (plus R) fitted into the image */
	pitch = fmax((sz.x + 2 * so.support_mm) / w, (sz.y + 2 * so.support_mm) / hh);
	memset(&map, 0, sizeof map);
	map.a[0][0] = map.a[1][1] = 1 / pitch;
	map.b[0] = -(h.bbox.lo.x - so.support_mm) / pitch;
	map.b[1] = -(h.bbox.lo.y - so.support_mm) / pitch;
	r = raster_new(w, hh);
	if (!r || lattice_slicer_new(lattice_stream_source(st), &so, &sl, &e)) {
		fprintf(stderr, "slice: cannot start\n");
		return 1;
	}
	for (int k = 0; k < layers; k++) {
		double z = h.bbox.lo.z + (k + 0.5) * sz.z / layers, t1 = progress_now_s();
		if (lattice_slicer_render(sl, z, &map, r, NULL, 0, 0, &e)) {
			fprintf(stderr, "slice: %s\n", e.msg);
			return 1;
		}
		t_render += progress_now_s() - t1;
		area += raster_coverage_px(r);
	}
	lattice_slicer_get_stats(sl, &ss);
	printf("slice_struts %llu\nslice_struts_read %llu\nslice_layers %d\nslice_image %dx%d\n"
	       "slice_pixel_um %.2f\nslice_seconds_per_slice %.4f\nslice_seconds_total %.2f\n"
	       "slice_max_active %zu\nslice_window_nodes %zu\nslice_kernel_evals %llu\n"
	       "slice_mean_coverage %.4f\nslice_rss_mb %.1f\n",
	       (unsigned long long)h.nedges, (unsigned long long)ss.struts_read, layers, w, hh,
	       pitch * 1000, t_render / layers, progress_now_s() - t0, ss.max_active,
	       lattice_stream_window_peak(st), (unsigned long long)ss.pairs,
	       area / layers / ((double)w * hh), peak_rss_mb());
	lattice_slicer_free(sl);
	lattice_stream_free(st);
	raster_free(r);
	return 0;
}

int main(int argc, char **argv)
{
	int rc = 2;

	if (argc > 1 && !strcmp(argv[1], "gen"))
		rc = cmd_gen(argc, argv);
	else if (argc > 1 && !strcmp(argv[1], "grid"))
		rc = cmd_grid(argc, argv);
	else if (argc > 1 && !strcmp(argv[1], "slice"))
		rc = cmd_slice(argc, argv);
	if (rc == 2)
		fprintf(stderr, "usage: see the comment at the top of tests/bench/bench_lattice.c\n");
	return rc;
}
