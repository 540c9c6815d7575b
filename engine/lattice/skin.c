/* skin.c - solid skin around a lattice (skin.h): part slice, 3D erosion,
 * polygon booleans (regions) or pixel min/max (rasters). */
#include "engine/lattice/skin.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/geom/clip.h"
#include "engine/geom/vec.h"
#include "engine/slice/erode.h"
#include "engine/slice/layer.h"
#include "engine/slice/slice.h"

#include <string.h>

struct lattice_skin {
	struct slicer *part;    /* the part at the layer being printed */
	struct slice_mid_source ahead; /* the eroder's own slices, running ahead (slicer owned) */
	struct slice_eroder *eroder;
	double layer_mm;
	int last_k;
	struct paths region, cavity, shell, tmp;
	struct raster *pr, *sr; /* part and skin pixels (raster output) */
	double area_mm2;
};

int lattice_skin_new(const struct mesh *m, double shell_mm, double pixel_mm, double layer_mm,
		     double z_top_mm, double x0, double y0, double x1, double y1,
		     struct lattice_skin **out, struct err *e)
{
	struct lattice_skin *s = mem_calloc(1, sizeof *s);
	struct box3 bb = {{x0, y0, 0}, {x1, y1, z_top_mm}};
	int rc;

	if (!s)
		return ERR_SET(e, ERR_NOMEM, "out of memory");
	s->layer_mm = layer_mm;
	s->last_k = -1;
	paths_init(&s->region);
	paths_init(&s->cavity);
	paths_init(&s->shell);
	paths_init(&s->tmp);
	if ((rc = slice_new(m, &s->part, e)) != 0 ||
	    (rc = slice_erode_mesh_new(m, shell_mm, pixel_mm, layer_mm,
				       layer_count_for(z_top_mm, layer_mm), &bb, &s->ahead,
				       &s->eroder, e)) != 0) {
		lattice_skin_free(s);
		return rc;
	}
	*out = s;
	return 0;
}

void lattice_skin_free(struct lattice_skin *s)
{
	if (!s)
		return;
	slice_erode_free(s->eroder);
	slice_free(s->part);
	slice_free(s->ahead.slicer);
	paths_fini(&s->region);
	paths_fini(&s->cavity);
	paths_fini(&s->shell);
	paths_fini(&s->tmp);
	raster_free(s->pr);
	raster_free(s->sr);
	mem_free(s);
}

double lattice_skin_area_mm2(const struct lattice_skin *s)
{
	return s->area_mm2;
}

/* Part region and skin of layer k (cached for the same k). */
static int layer_shapes(struct lattice_skin *s, int k, double z_mm, struct err *e)
{
	int rc;

	if (k == s->last_k)
		return 0;
	if ((rc = slice_at(s->part, z_mm, &s->region, NULL, e)) != 0 ||
	    (rc = slice_erode_layer(s->eroder, k, &s->cavity, e)) != 0 ||
	    (rc = clip_boolean(CLIP_DIFFERENCE, &s->region, &s->cavity, CLIP_FILL_NONZERO,
			       &s->shell, e)) != 0)
		return rc;
	s->last_k = k;
	s->area_mm2 += paths_area_mm2(&s->shell);
	return 0;
}

int lattice_skin_region(struct lattice_skin *s, int k, double z_mm, struct paths *region,
			struct err *e)
{
	int rc;

	if ((rc = layer_shapes(s, k, z_mm, e)) != 0)
		return rc;
	if ((rc = clip_boolean(CLIP_INTERSECTION, region, &s->region, CLIP_FILL_NONZERO, &s->tmp,
			       e)) != 0)
		return rc;
	return clip_boolean(CLIP_UNION, &s->tmp, &s->shell, CLIP_FILL_NONZERO, region, e);
}

int lattice_skin_raster(struct lattice_skin *s, int k, double z_mm, const struct raster_map *map,
			int antialias, struct raster *r, struct err *e)
{
	int rc;

	if ((rc = layer_shapes(s, k, z_mm, e)) != 0)
		return rc;
	if (!s->pr || s->pr->w != r->w || s->pr->h != r->h) {
		raster_free(s->pr);
		raster_free(s->sr);
		s->pr = raster_new(r->w, r->h);
		s->sr = raster_new(r->w, r->h);
		if (!s->pr || !s->sr)
			return ERR_SET(e, ERR_NOMEM, "out of memory for skin images");
	}
	raster_clear(s->pr);
	raster_clear(s->sr);
	if ((rc = slice_rasterize(&s->region, map, antialias, s->pr, e)) != 0 ||
	    (rc = slice_rasterize(&s->shell, map, antialias, s->sr, e)) != 0)
		return rc;
	for (int j = 0; j < r->h; j++) {
		uint8_t *o = r->px + (size_t)j * r->stride;
		const uint8_t *p = s->pr->px + (size_t)j * s->pr->stride;
		const uint8_t *q = s->sr->px + (size_t)j * s->sr->stride;
		for (int i = 0; i < r->w; i++) {
			uint8_t v = o[i] < p[i] ? o[i] : p[i];
			o[i] = v > q[i] ? v : q[i];
		}
	}
	return 0;
}
