/* vtk.c - VTK XML ImageData writer for the FEA model (see vtk.h).
 *
 * Layout (VTK "XML File Formats", ImageData, appended raw data): the XML
 * head declares every DataArray with format="appended" and its offset,
 * the byte position after the AppendedData section's leading '_' where
 * its block starts; a block is an UInt64 byte count then the values.
 * Values are converted to float in chunks, so memory stays a few KB
 * beyond the caller's arrays.
 */
#include "engine/fea/vtk.h"

#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "engine/core/err.h"

/* Values converted per fwrite. */
#define VTK_CHUNK 4096

struct vtk_array {
	const char *name;
	int components;
	const float *f;  /* values as float, or */
	const double *d; /* as double (converted) */
	uint64_t count;  /* values (components per tuple included) */
};

static int host_little_endian(void)
{
	const uint16_t one = 1;
	return *(const unsigned char *)&one == 1;
}

static int write_block(FILE *fp, const struct vtk_array *a)
{
	uint64_t bytes = a->count * sizeof(float);
	float buf[VTK_CHUNK];

	if (fwrite(&bytes, sizeof bytes, 1, fp) != 1)
		return -1;
	if (a->f)
		return fwrite(a->f, sizeof(float), (size_t)a->count, fp) == (size_t)a->count ? 0 : -1;
	for (uint64_t i = 0; i < a->count; i += VTK_CHUNK) {
		size_t n = (size_t)(a->count - i < VTK_CHUNK ? a->count - i : VTK_CHUNK);
		for (size_t k = 0; k < n; k++)
			buf[k] = (float)a->d[i + k];
		if (fwrite(buf, sizeof(float), n, fp) != n)
			return -1;
	}
	return 0;
}

static void declare(FILE *fp, const struct vtk_array *a, uint64_t *offset)
{
	fprintf(fp, "        <DataArray type=\"Float32\" Name=\"%s\"", a->name);
	if (a->components > 1)
		fprintf(fp, " NumberOfComponents=\"%d\"", a->components);
	fprintf(fp, " format=\"appended\" offset=\"%llu\"/>\n", (unsigned long long)*offset);
	*offset += sizeof(uint64_t) + a->count * sizeof(float);
}

int fea_vtk_write(const char *path, const struct fea_grid *g, const struct fea_vtk_fields *f,
		  struct err *e)
{
	char tmp[4096];
	uint64_t cells = (uint64_t)g->nx * g->ny * g->nz;
	uint64_t points = (uint64_t)(g->nx + 1) * (g->ny + 1) * (g->nz + 1), offset = 0;
	struct vtk_array pt[1], cl[3];
	int npt = 0, ncl = 0, bad;
	FILE *fp;

	if ((size_t)snprintf(tmp, sizeof tmp, "%s.part", path) >= sizeof tmp)
		return ERR_SET(e, ERR_LIMIT, "VTK path too long: %s", path);
	if (f->displacement_mm)
		pt[npt++] = (struct vtk_array){"displacement", 3, NULL, f->displacement_mm,
					       3 * points};
	cl[ncl++] = (struct vtk_array){"density", 1, g->rho, NULL, cells};
	if (f->von_mises_mpa)
		cl[ncl++] = (struct vtk_array){"von_mises_mpa", 1, f->von_mises_mpa, NULL, cells};
	if (f->strain_energy)
		cl[ncl++] = (struct vtk_array){"strain_energy", 1, f->strain_energy, NULL, cells};
	fp = fopen(tmp, "wb");
	if (!fp)
		return ERR_SET(e, ERR_IO, "cannot create %s: %s", tmp, strerror(errno));
	fprintf(fp,
		"<?xml version=\"1.0\"?>\n"
		"<VTKFile type=\"ImageData\" version=\"1.0\" byte_order=\"%s\" "
		"header_type=\"UInt64\">\n"
		"  <ImageData WholeExtent=\"0 %d 0 %d 0 %d\" Origin=\"%.9g %.9g %.9g\" "
		"Spacing=\"%.9g %.9g %.9g\">\n"
		"    <Piece Extent=\"0 %d 0 %d 0 %d\">\n",
		host_little_endian() ? "LittleEndian" : "BigEndian", g->nx, g->ny, g->nz,
		g->lo_mm.x, g->lo_mm.y, g->lo_mm.z, g->h_mm, g->h_mm, g->h_mm, g->nx, g->ny, g->nz);
	if (npt) {
		fprintf(fp, "      <PointData Vectors=\"displacement\">\n");
		for (int i = 0; i < npt; i++)
			declare(fp, &pt[i], &offset);
		fprintf(fp, "      </PointData>\n");
	}
	fprintf(fp, "      <CellData Scalars=\"density\">\n");
	for (int i = 0; i < ncl; i++)
		declare(fp, &cl[i], &offset);
	fprintf(fp, "      </CellData>\n    </Piece>\n  </ImageData>\n"
		    "  <AppendedData encoding=\"raw\">\n   _");
	bad = 0;
	for (int i = 0; !bad && i < npt; i++)
		bad = write_block(fp, &pt[i]);
	for (int i = 0; !bad && i < ncl; i++)
		bad = write_block(fp, &cl[i]);
	if (!bad)
		fprintf(fp, "\n  </AppendedData>\n</VTKFile>\n");
	bad |= ferror(fp) != 0;
	bad |= fflush(fp) != 0 || fsync(fileno(fp)) != 0;
	if (fclose(fp) != 0)
		bad = 1;
	if (bad || rename(tmp, path) != 0) {
		int err = errno;
		unlink(tmp);
		return ERR_SET(e, ERR_IO, "cannot write %s: %s", path, strerror(err));
	}
	return 0;
}
