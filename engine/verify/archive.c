/* archive.c - verify_archive(): the layer checker on a written SL1/SL1S or
 * plain zip of PNG layers, read back with libarchive and
 * engine/output/image/image.h.
 *
 * Entries are read once in archive order: config.ini and prusaslicer.ini
 * are parsed, layer PNGs (every *.png outside thumbnail/) kept compressed
 * in memory (a few KB each), then decoded one at a time in file-name order
 * (zero-padded names sort in print order) and fed to the checker, so at
 * most one decoded image exists at a time (two with a reference archive,
 * read in lockstep).  Every size read from the archive is checked before
 * allocating.
 */
#include "engine/verify/verify.h"

#include <archive.h>
#include <archive_entry.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/output/image/image.h"
#include "engine/output/printer/printer.h"

#define VA_MAX_ENTRY (64u << 20)  /* largest entry read (bytes) */
#define VA_MAX_TOTAL (4ull << 30) /* all layer PNGs together */
#define VA_MAX_INI (1u << 20)
#define VA_MAX_LAYERS 200000

struct png_ent {
	char *name;
	unsigned char *data;
	size_t len;
};

struct ini_vals {
	double layer_mm;
	double disp_w, disp_h;
	double pix_x, pix_y;
	int portrait;
	int mirror_x, mirror_y;
	int has_map;           /* manifest.json (plain zip) gave map */
	struct raster_map map; /* its map_mm_to_px */
};

/* Print order of layer names: digit runs compare as numbers, so the zip
 * writer's unpadded "2.png" comes before "10.png"; SL1's zero-padded
 * names keep their plain order. */
static int cmp_ent(const void *a, const void *b)
{
	const char *p = ((const struct png_ent *)a)->name, *q = ((const struct png_ent *)b)->name;

	while (*p && *q) {
		if (*p >= '0' && *p <= '9' && *q >= '0' && *q <= '9') {
			const char *p0 = p, *q0 = q;
			size_t lp, lq;
			int c;
			while (*p0 == '0' && p0[1] >= '0' && p0[1] <= '9')
				p0++;
			while (*q0 == '0' && q0[1] >= '0' && q0[1] <= '9')
				q0++;
			for (p = p0; *p >= '0' && *p <= '9'; p++)
				;
			for (q = q0; *q >= '0' && *q <= '9'; q++)
				;
			lp = (size_t)(p - p0);
			lq = (size_t)(q - q0);
			if (lp != lq)
				return lp < lq ? -1 : 1;
			if ((c = memcmp(p0, q0, lp)) != 0)
				return c;
			continue;
		}
		if (*p != *q)
			return (unsigned char)*p < (unsigned char)*q ? -1 : 1;
		p++;
		q++;
	}
	if (*p || *q)
		return *p ? 1 : -1;
	return strcmp(((const struct png_ent *)a)->name, ((const struct png_ent *)b)->name);
}

/* Value of `key = value` in INI text (NUL-terminated), or NULL. */
static const char *ini_get(const char *text, const char *key, char *buf, size_t len)
{
	size_t kl = strlen(key);

	for (const char *l = text; l && *l; l = strchr(l, '\n') ? strchr(l, '\n') + 1 : NULL) {
		const char *p = l;
		while (*p == ' ' || *p == '\t')
			p++;
		if (strncmp(p, key, kl) != 0)
			continue;
		p += kl;
		while (*p == ' ' || *p == '\t')
			p++;
		if (*p != '=')
			continue;
		p++;
		while (*p == ' ' || *p == '\t')
			p++;
		size_t n = strcspn(p, "\r\n");
		if (n >= len)
			n = len - 1;
		memcpy(buf, p, n);
		buf[n] = 0;
		return buf;
	}
	return NULL;
}

static void parse_ini(const char *text, struct ini_vals *iv)
{
	char b[128];

	if (ini_get(text, "layerHeight", b, sizeof b))
		iv->layer_mm = atof(b);
	if (ini_get(text, "display_width", b, sizeof b))
		iv->disp_w = atof(b);
	if (ini_get(text, "display_height", b, sizeof b))
		iv->disp_h = atof(b);
	if (ini_get(text, "display_pixels_x", b, sizeof b))
		iv->pix_x = atof(b);
	if (ini_get(text, "display_pixels_y", b, sizeof b))
		iv->pix_y = atof(b);
	if (ini_get(text, "display_orientation", b, sizeof b))
		iv->portrait = strcmp(b, "portrait") == 0;
	if (ini_get(text, "display_mirror_x", b, sizeof b))
		iv->mirror_x = atoi(b) != 0;
	if (ini_get(text, "display_mirror_y", b, sizeof b))
		iv->mirror_y = atoi(b) != 0;
}

/* The numbers of `"key": [n, n, n]` (count of them) in our own
 * manifest.json; 0 or -1 when absent or malformed. */
static int manifest_numbers(const char *text, const char *key, double *out, int count)
{
	const char *p = strstr(text, key);
	char *end;

	if (!p)
		return -1;
	p += strlen(key);
	while (*p == ' ' || *p == ':' || *p == '\t' || *p == '\n')
		p++;
	if (count > 1 && *p++ != '[')
		return -1;
	for (int i = 0; i < count; i++) {
		while (*p == ' ' || *p == ',' || *p == '\n')
			p++;
		out[i] = strtod(p, &end);
		if (end == p || !isfinite(out[i]))
			return -1;
		p = end;
	}
	return 0;
}

/* manifest.json of a plain zip stack (sl1_manifest_json): layer height
 * and the printer-mm -> pixel map, which a zip carries in no ini. */
static void parse_manifest(const char *text, struct ini_vals *iv)
{
	double lh, u[3], v[3];
	const char *map;

	/* keys with their colon: a string value (the job name) escapes its
	 * quotes, so it cannot hold one */
	if (!strstr(text, "\"infilld-png-stack\""))
		return;
	if (manifest_numbers(text, "\"layer_height_mm\":", &lh, 1) == 0 && lh > 0)
		iv->layer_mm = lh;
	map = strstr(text, "\"map_mm_to_px\":");
	if (map && manifest_numbers(map, "\"u\":", u, 3) == 0 &&
	    manifest_numbers(map, "\"v\":", v, 3) == 0) {
		iv->map.a[0][0] = u[0];
		iv->map.a[0][1] = u[1];
		iv->map.b[0] = u[2];
		iv->map.a[1][0] = v[0];
		iv->map.a[1][1] = v[1];
		iv->map.b[1] = v[2];
		iv->has_map = fabs(u[0] * v[1] - u[1] * v[0]) > 0;
	}
}

static int read_entry(struct archive *a, size_t size, unsigned char **out, const char *name,
		      struct err *e)
{
	unsigned char *buf = mem_alloc(size + 1);
	size_t got = 0;

	if (!buf)
		return ERR_SET(e, ERR_NOMEM, "verify: out of memory reading %s", name);
	while (got < size) {
		la_ssize_t r = archive_read_data(a, buf + got, size - got);
		if (r < 0) {
			mem_free(buf);
			return ERR_SET(e, ERR_PARSE, "verify: reading %s: %s", name,
				       archive_error_string(a));
		}
		if (r == 0)
			break;
		got += (size_t)r;
	}
	if (got != size) {
		mem_free(buf);
		return ERR_SET(e, ERR_PARSE, "verify: %s is truncated (%zu of %zu bytes)", name, got,
			       size);
	}
	buf[size] = 0;
	*out = buf;
	return 0;
}

/* The layer PNGs of one archive (compressed, sorted by name) and its ini
 * values.  Owned; layer_set_fini() frees. */
struct layer_set {
	struct png_ent *L;
	size_t n, cap;
	struct ini_vals iv;
};

static void layer_set_fini(struct layer_set *ls)
{
	for (size_t k = 0; k < ls->n; k++) {
		mem_free(ls->L[k].name);
		mem_free(ls->L[k].data);
	}
	mem_free(ls->L);
	memset(ls, 0, sizeof *ls);
}

/* Read path's entries once: ini files parsed, layer PNGs kept compressed
 * and sorted by name.  ls must be zeroed; on failure it holds what was
 * read (layer_set_fini frees it). */
static int load_layers(const char *path, struct layer_set *ls, struct err *e)
{
	struct archive *a = archive_read_new();
	struct archive_entry *ent;
	unsigned long long total = 0;
	int rc = 0, r;

	if (!a)
		return ERR_SET(e, ERR_NOMEM, "verify: out of memory");
	archive_read_support_format_zip(a);
	archive_read_support_filter_all(a);
	if (archive_read_open_filename(a, path, 1 << 16) != ARCHIVE_OK) {
		rc = ERR_SET(e, ERR_IO, "verify: cannot open %s: %s", path, archive_error_string(a));
		goto out;
	}
	while ((r = archive_read_next_header(a, &ent)) == ARCHIVE_OK) {
		const char *name = archive_entry_pathname(ent);
		la_int64_t sz = archive_entry_size(ent);
		size_t nl = name ? strlen(name) : 0;
		unsigned char *data = NULL;
		if (!name || archive_entry_filetype(ent) != AE_IFREG)
			continue;
		if (strcmp(name, "config.ini") == 0 || strcmp(name, "prusaslicer.ini") == 0 ||
		    strcmp(name, "manifest.json") == 0) {
			if (sz < 0 || (unsigned long long)sz > VA_MAX_INI)
				continue;
			rc = read_entry(a, (size_t)sz, &data, name, e);
			if (rc)
				goto out;
			if (name[0] == 'm')
				parse_manifest((const char *)data, &ls->iv);
			else
				parse_ini((const char *)data, &ls->iv);
			mem_free(data);
			continue;
		}
		if (nl < 5 || strcmp(name + nl - 4, ".png") != 0 || strncmp(name, "thumbnail/", 10) == 0)
			continue;
		if (sz <= 0 || (unsigned long long)sz > VA_MAX_ENTRY) {
			rc = ERR_SET(e, ERR_LIMIT, "verify: layer %s has size %lld (max %u)", name,
				     (long long)sz, VA_MAX_ENTRY);
			goto out;
		}
		total += (unsigned long long)sz;
		if (total > VA_MAX_TOTAL || ls->n >= VA_MAX_LAYERS) {
			rc = ERR_SET(e, ERR_LIMIT, "verify: %s has too many or too large layers", path);
			goto out;
		}
		if (ls->n == ls->cap) {
			void *arr = ls->L;
			if (mem_grow(&arr, &ls->cap, ls->n + 1, sizeof *ls->L)) {
				rc = ERR_SET(e, ERR_NOMEM, "verify: out of memory");
				goto out;
			}
			ls->L = arr;
		}
		memset(&ls->L[ls->n], 0, sizeof ls->L[ls->n]);
		ls->L[ls->n].name = mem_strdup(name);
		if (!ls->L[ls->n].name) {
			rc = ERR_SET(e, ERR_NOMEM, "verify: out of memory");
			goto out;
		}
		ls->n++;
		rc = read_entry(a, (size_t)sz, &ls->L[ls->n - 1].data, name, e);
		if (rc)
			goto out;
		ls->L[ls->n - 1].len = (size_t)sz;
	}
	if (r != ARCHIVE_EOF) {
		rc = ERR_SET(e, ERR_PARSE, "verify: %s: %s", path, archive_error_string(a));
		goto out;
	}
	if (ls->n == 0) {
		rc = ERR_SET(e, ERR_PARSE, "verify: %s holds no layer images", path);
		goto out;
	}
	qsort(ls->L, ls->n, sizeof *ls->L, cmp_ent);
out:
	archive_read_free(a);
	return rc;
}

/* Decode ent into *img (reallocated when its size differs; caller frees
 * with raster_free), keeping ent's compressed copy.  Reentrant: calls
 * for distinct img may run at once. */
static int decode_png(const struct png_ent *ent, struct raster **img, struct err *e)
{
	int rc = out_png_decode_gray(ent->data, ent->len, img, e);

	if (rc)
		err_prefix(e, "verify: %s", ent->name);
	return rc;
}

/* decode_png, then drop ent's compressed copy early. */
static int decode_layer(struct png_ent *ent, struct raster **img, struct err *e)
{
	int rc = decode_png(ent, img, e);

	if (!rc) {
		mem_free(ent->data);
		ent->data = NULL;
	}
	return rc;
}

int verify_archive(const char *path, const struct verify_params *p, struct verify_report *out,
		   struct err *e)
{
	return verify_archive_ref(path, NULL, p, out, e);
}

int verify_archive_ref(const char *path, const char *ref_path, const struct verify_params *p,
		       struct verify_report *out, struct err *e)
{
	struct layer_set ls, rs;
	struct verify_params vp = *p;
	struct verify *v = NULL;
	struct raster *img = NULL, *rimg = NULL;
	int rc;

	memset(&ls, 0, sizeof ls);
	memset(&rs, 0, sizeof rs);
	if ((rc = load_layers(path, &ls, e)) != 0)
		goto out;
	if (ref_path && (rc = load_layers(ref_path, &rs, e)) != 0) {
		err_prefix(e, "reference");
		goto out;
	}
	if (!(vp.layer_mm > 0))
		vp.layer_mm = ls.iv.layer_mm;
	if (!(vp.pixel_x_mm > 0) || !(vp.pixel_y_mm > 0)) {
		const struct ini_vals *iv = &ls.iv;
		if (iv->disp_w > 0 && iv->disp_h > 0 && iv->pix_x > 0 && iv->pix_y > 0) {
			/* portrait: image columns run along the display's short side */
			vp.pixel_x_mm = iv->portrait ? iv->disp_h / iv->pix_y : iv->disp_w / iv->pix_x;
			vp.pixel_y_mm = iv->portrait ? iv->disp_w / iv->pix_x : iv->disp_h / iv->pix_y;
		}
	}
	if (!(vp.layer_mm > 0) || !(vp.pixel_x_mm > 0)) {
		rc = ERR_SET(e, ERR_PARSE,
			     "verify: %s does not state its layer height and pixel size "
			     "(config.ini layerHeight, prusaslicer.ini display_*); give them",
			     path);
		goto out;
	}
	rc = verify_new(&vp, &v, e);
	if (rc)
		goto out;
	for (size_t k = 0; k < ls.n; k++) {
		if ((rc = decode_layer(&ls.L[k], &img, e)) != 0)
			goto out;
		if (ref_path && k < rs.n && (rc = decode_layer(&rs.L[k], &rimg, e)) != 0) {
			err_prefix(e, "reference");
			goto out;
		}
		if (ref_path && k == rs.n && rimg)
			raster_clear(rimg); /* above the reference's top: empty */
		rc = verify_layer_ref(v, img, ref_path ? rimg : NULL, e);
		if (rc)
			goto out;
	}
	rc = verify_finish(v, out, e);
out:
	verify_free(v);
	raster_free(img);
	raster_free(rimg);
	layer_set_fini(&ls);
	layer_set_fini(&rs);
	return rc;
}

/* An opened archive for verify_stack_*: its compressed layers. */
struct verify_stack_reader {
	struct layer_set ls;
};

int verify_stack_open(const char *path, struct verify_stack_reader **out, struct verify_stack *st,
		      struct err *e)
{
	struct verify_stack_reader *r = mem_calloc(1, sizeof *r);
	const struct ini_vals *iv;
	struct verify_stack info;
	int rc;

	if (!r)
		return ERR_SET(e, ERR_NOMEM, "verify: out of memory");
	memset(&info, 0, sizeof info);
	if ((rc = load_layers(path, &r->ls, e)) != 0)
		goto out;
	iv = &r->ls.iv;
	info.layers = (int)r->ls.n;
	info.layer_mm = iv->layer_mm > 0 ? iv->layer_mm : 0;
	if (iv->has_map) {
		info.map = iv->map;
		info.has_map = 1;
	} else if (iv->disp_w > 0 && iv->disp_h > 0 && iv->pix_x >= 1 && iv->pix_y >= 1 &&
		   iv->pix_x <= 65535 && iv->pix_y <= 65535) {
		/* the SL1 writer's own map from the display it states */
		struct printer p;
		int w, h;
		memset(&p, 0, sizeof p);
		p.kind = PRINTER_RESIN;
		p.resin.pixels_x = (int)iv->pix_x;
		p.resin.pixels_y = (int)iv->pix_y;
		p.resin.display_w_mm = iv->disp_w;
		p.resin.display_h_mm = iv->disp_h;
		p.resin.portrait = iv->portrait;
		p.resin.mirror_x = iv->mirror_x;
		p.resin.mirror_y = iv->mirror_y;
		printer_raster_geometry(&p, &info.map, &w, &h);
		info.has_map = 1;
	}
	/* the image size from the first layer's header */
	if ((rc = out_png_size(r->ls.L[0].data, r->ls.L[0].len, &info.width, &info.height, e)) !=
	    0) {
		err_prefix(e, "verify: %s", r->ls.L[0].name);
		goto out;
	}
out:
	if (rc) {
		verify_stack_close(r);
		return rc;
	}
	*st = info;
	*out = r;
	return 0;
}

int verify_stack_layer(const struct verify_stack_reader *r, int k, struct raster **img,
		       struct err *e)
{
	if (k < 0 || (size_t)k >= r->ls.n)
		return ERR_SET(e, ERR_INTERNAL, "verify: no layer %d of %zu", k, r->ls.n);
	return decode_png(&r->ls.L[k], img, e);
}

void verify_stack_close(struct verify_stack_reader *r)
{
	if (!r)
		return;
	layer_set_fini(&r->ls);
	mem_free(r);
}
