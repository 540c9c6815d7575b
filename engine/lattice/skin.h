/* skin.h - an optional solid skin around a generated lattice (shell_mm).
 *
 * The paper prints bare lattices; with shell_mm > 0 the part gets a skin:
 * per layer, skin = part region minus the part eroded in 3D by shell_mm
 * (slice/erode.h, exact to its pixel), and the lattice is clipped to the
 * part, so a layer is (lattice AND part) OR skin.  Struts on the part's
 * surface merge into the skin.  Internal to lattice/.
 */
#ifndef INFILLD_LATTICE_SKIN_H
#define INFILLD_LATTICE_SKIN_H

#include "engine/geom/path.h"
#include "engine/geom/raster.h"

struct err;
struct mesh;
struct lattice_skin;

/* m: the placed part (borrowed); bbox its box; pixel_mm the erosion grid
 * pitch.  Caller frees with lattice_skin_free(). */
int lattice_skin_new(const struct mesh *m, double shell_mm, double pixel_mm, double layer_mm,
		     double z_top_mm, double x0, double y0, double x1, double y1,
		     struct lattice_skin **out, struct err *e);
void lattice_skin_free(struct lattice_skin *s);

/* Layer k (sampled at z_mm): r = max(min(r, part), skin) through map. */
int lattice_skin_raster(struct lattice_skin *s, int k, double z_mm, const struct raster_map *map,
			int antialias, struct raster *r, struct err *e);
/* Layer k: region = (region AND part) OR skin. */
int lattice_skin_region(struct lattice_skin *s, int k, double z_mm, struct paths *region,
			struct err *e);
/* Skin area summed over the layers so far (mm^2). */
double lattice_skin_area_mm2(const struct lattice_skin *s);

#endif
