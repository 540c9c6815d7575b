/* vtk.h - a solved voxel model as a VTK XML ImageData file (.vti), for
 * ParaView (docs/fea_cli.md, "VTK output").
 *
 * One piece over the whole grid: point extent 0..nx x 0..ny x 0..nz,
 * Origin = the grid's lo_mm, Spacing = h_mm (printer frame, mm), so VTK's
 * point and cell order (x fastest, then y, then z) is fea.h's node and
 * element order.  Arrays are Float32, raw binary in an appended section
 * (header_type UInt64, the host's byte order), each preceded by its byte
 * count as the VTK XML format requires.
 */
#ifndef INFILLD_FEA_VTK_H
#define INFILLD_FEA_VTK_H

#include "engine/fea/fea.h"

struct err;

/* The arrays written; each NULL is left out of the file. */
struct fea_vtk_fields {
	const double *displacement_mm; /* 3 per node (fea_displacement): PointData
					  "displacement" */
	const float *von_mises_mpa;    /* per element: CellData "von_mises_mpa" */
	const float *strain_energy;    /* per element, N mm: CellData "strain_energy" */
};

/* Write g (CellData "density" = g->rho) and f to path: written to
 * "<path>.part" and renamed into place only when complete, so a failure
 * leaves no partial file.  0, ERR_IO (naming the file and errno text) or
 * ERR_LIMIT (path too long). */
int fea_vtk_write(const char *path, const struct fea_grid *g, const struct fea_vtk_fields *f,
		  struct err *e);

#endif
