/* test_file.c - lattice files: binary and text round trips, the streaming
 * writer, malformed input reported with its place, allocation failures. */
#include "harness.h"

#include <unistd.h>

#include "engine/core/err.h"
#include "engine/core/mem.h"
#include "engine/core/sink.h"
#include "engine/lattice/lattice.h"
#include "engine/lattice/strut.h"

static double rnd(unsigned long long *s)
{
	*s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
	return (double)(*s >> 11) / 9007199254740992.0;
}

static struct lattice *random_lattice(int n, unsigned long long seed)
{
	struct lattice *q = lattice_new();

	for (int i = 0; i < n; i++)
		lattice_add_node(q, v3(50 * rnd(&seed) - 25, 50 * rnd(&seed), 30 * rnd(&seed)));
	for (int i = 0; i < 4 * n; i++) {
		uint32_t a = (uint32_t)(rnd(&seed) * n), b = (uint32_t)(rnd(&seed) * n);
		if (a != b)
			lattice_add_edge(q, a, b, 0.1 + 0.4 * rnd(&seed));
	}
	q->support_mm = 0.9;
	return q;
}

/* Struts as sorted (a, b, r) records of coordinates: a file may renumber
 * nodes, so compare geometry. */
struct rec {
	double v[7];
};

static int cmp_rec(const void *pa, const void *pb)
{
	const struct rec *a = pa, *b = pb;
	for (int i = 0; i < 7; i++)
		if (a->v[i] != b->v[i])
			return a->v[i] < b->v[i] ? -1 : 1;
	return 0;
}

static struct rec *records(const struct lattice *q)
{
	struct rec *r = mem_alloc(q->nedges * sizeof *r);
	for (size_t i = 0; i < q->nedges; i++) {
		struct lattice_strut s;
		lattice_strut_make(&s, q->node[q->edge[i].a], q->node[q->edge[i].b],
				   q->edge[i].radius_mm);
		for (int k = 0; k < 3; k++) {
			r[i].v[k] = s.a[k];
			r[i].v[3 + k] = s.b[k];
		}
		r[i].v[6] = 0; /* radii compared separately (quantised) */
	}
	qsort(r, q->nedges, sizeof *r, cmp_rec);
	return r;
}

static const char *tmp_file(char *buf)
{
	int fd;
	strcpy(buf, "/tmp/infilld-latfile-XXXXXX");
	fd = mkstemp(buf);
	if (fd >= 0)
		close(fd);
	return buf;
}

static void test_binary_round_trip(void)
{
	struct err e;
	char path[64];
	struct lattice *q = random_lattice(300, 4), *r = NULL;
	struct rec *a, *b;
	double qmax = lattice_max_radius(q) / 65535, worst = 0;

	REQUIRE_OK(lattice_write_binary(q, tmp_file(path), &e), &e);
	CHECK_EQ_INT(lattice_file_probe(path), LATTICE_FILE_BINARY);
	REQUIRE_OK(lattice_read(path, &r, &e), &e);
	CHECK_EQ_INT(r->nnodes, q->nnodes);
	CHECK_EQ_INT(r->nedges, q->nedges);
	CHECK_NUM(r->support_mm, ==, 0.9);
	/* nodes sorted by z, edges by their lower node */
	for (size_t i = 1; i < r->nnodes; i++)
		CHECK_NUM(r->node[i].z, >=, r->node[i - 1].z);
	for (size_t i = 0; i < r->nedges; i++) {
		CHECK_INT(r->edge[i].a, <, r->edge[i].b);
		if (i)
			CHECK_INT(r->edge[i].a, >=, r->edge[i - 1].a);
	}
	a = records(q);
	b = records(r);
	CHECK(memcmp(a, b, q->nedges * sizeof *a) == 0); /* same struts, float coordinates */
	/* radius quantisation error at most half a quantum: compare the sums
	 * of sorted radii lists */
	{
		float *ra = mem_alloc(q->nedges * sizeof *ra), *rb = mem_alloc(q->nedges * sizeof *rb);
		for (size_t i = 0; i < q->nedges; i++) {
			ra[i] = q->edge[i].radius_mm;
			rb[i] = r->edge[i].radius_mm;
		}
		for (size_t i = 0; i < q->nedges; i++)
			for (size_t j = i + 1; j < q->nedges; j++) {
				if (ra[j] < ra[i]) { float t = ra[i]; ra[i] = ra[j]; ra[j] = t; }
				if (rb[j] < rb[i]) { float t = rb[i]; rb[i] = rb[j]; rb[j] = t; }
			}
		for (size_t i = 0; i < q->nedges; i++)
			worst = fmax(worst, fabs(ra[i] - rb[i]));
		mem_free(ra);
		mem_free(rb);
	}
	CHECK_NUM(worst, <=, 0.5 * qmax * 1.0001 + 1e-7);
	mem_free(a);
	mem_free(b);
	lattice_free(q);
	lattice_free(r);
	unlink(path);
}

static void test_text_round_trip(void)
{
	struct err e;
	struct buf b;
	struct sink s;
	struct lattice *q = random_lattice(50, 8), *r = NULL;

	buf_init(&b);
	sink_init_buf(&s, &b);
	REQUIRE_OK(lattice_write_text(q, &s, &e), &e);
	CHECK_EQ_INT(lattice_file_probe_buffer(b.data, b.len), LATTICE_FILE_TEXT);
	REQUIRE_OK(lattice_read_buffer(b.data, b.len, &r, &e), &e);
	CHECK_EQ_INT(r->nnodes, q->nnodes);
	CHECK_EQ_INT(r->nedges, q->nedges);
	CHECK(memcmp(r->node, q->node, q->nnodes * sizeof *q->node) == 0); /* exact */
	CHECK(memcmp(r->edge, q->edge, q->nedges * sizeof *q->edge) == 0);
	CHECK_NUM(r->support_mm, ==, q->support_mm);
	lattice_free(q);
	lattice_free(r);
	buf_fini(&b);
}

static void test_streaming_writer(void)
{
	struct err e;
	char path[64];
	struct lattice_writer *w;
	struct lattice *r = NULL;

	REQUIRE_OK(lattice_writer_open(tmp_file(path), 0, 1.0, &w, &e), &e);
	for (int i = 0; i < 10; i++)
		REQUIRE_OK(lattice_writer_node(w, v3(i, 0, 0.5 * i), &e), &e);
	for (uint32_t i = 0; i + 1 < 10; i++)
		REQUIRE_OK(lattice_writer_edge(w, i, i + 1, 0.25 + 0.05 * i, &e), &e);
	REQUIRE_OK(lattice_writer_close(w, &e), &e);
	REQUIRE_OK(lattice_read(path, &r, &e), &e);
	CHECK_EQ_INT(r->nnodes, 10);
	CHECK_EQ_INT(r->nedges, 9);
	CHECK_NEAR(r->edge[8].radius_mm, 0.65, 1e-4);
	CHECK_NUM(r->support_mm, ==, 0);
	lattice_free(r);

	/* order violations are refused */
	REQUIRE_OK(lattice_writer_open(path, 0, 1.0, &w, &e), &e);
	REQUIRE_OK(lattice_writer_node(w, v3(0, 0, 1), &e), &e);
	CHECK_EQ_INT(lattice_writer_node(w, v3(0, 0, 0.5), &e), ERR_PARAM);
	REQUIRE_OK(lattice_writer_node(w, v3(0, 0, 2), &e), &e);
	REQUIRE_OK(lattice_writer_node(w, v3(0, 0, 3), &e), &e);
	REQUIRE_OK(lattice_writer_edge(w, 1, 2, 0.5, &e), &e);
	CHECK_EQ_INT(lattice_writer_edge(w, 0, 1, 0.5, &e), ERR_PARAM); /* not sorted */
	CHECK_EQ_INT(lattice_writer_edge(w, 2, 1, 0.5, &e), ERR_PARAM); /* a > b */
	CHECK_EQ_INT(lattice_writer_edge(w, 1, 2, 1.5, &e), ERR_PARAM); /* radius bound */
	CHECK_EQ_INT(lattice_writer_node(w, v3(0, 0, 9), &e), ERR_PARAM); /* after edges */
	lattice_writer_abort(w);
	unlink(path);
}

/* Corruptions of a valid file, each reported with its byte offset and
 * item, never a crash. */
static void test_malformed_binary(void)
{
	struct err e;
	char path[64];
	struct lattice *q = random_lattice(20, 2), *r = NULL;
	unsigned char *data;
	size_t len;
	FILE *f;

	REQUIRE_OK(lattice_write_binary(q, tmp_file(path), &e), &e);
	f = fopen(path, "rb");
	REQUIRE(f);
	fseek(f, 0, SEEK_END);
	len = (size_t)ftell(f);
	fseek(f, 0, SEEK_SET);
	data = mem_alloc(len);
	REQUIRE(fread(data, 1, len, f) == len);
	fclose(f);
	/* truncated */
	CHECK_EQ_INT(lattice_read_buffer(data, len - 3, &r, &e), ERR_PARSE);
	CHECK_CONTAINS(e.msg, "bytes");
	/* nodes out of z order: swap the first two nodes' z */
	{
		unsigned char t[4];
		memcpy(t, data + 128 + 8, 4);
		memcpy(data + 128 + 8, data + 128 + 12 + 8, 4);
		memcpy(data + 128 + 12 + 8, t, 4);
		if (memcmp(data + 128 + 8, data + 128 + 20, 4) != 0) {
			CHECK_EQ_INT(lattice_read_buffer(data, len, &r, &e), ERR_PARSE);
			CHECK_CONTAINS(e.msg, "sorted by z");
			CHECK_EQ_INT(e.item, 1);
			CHECK_EQ_INT(e.offset, 128 + 12);
		}
		memcpy(data + 128 + 12 + 8, data + 128 + 8, 4);
		memcpy(data + 128 + 8, t, 4);
	}
	/* an edge pointing past the nodes */
	{
		size_t at = 128 + 12 * q->nnodes + 10 * 3 + 4;
		unsigned char save[4];
		memcpy(save, data + at, 4);
		memset(data + at, 0xff, 4);
		CHECK_EQ_INT(lattice_read_buffer(data, len, &r, &e), ERR_PARSE);
		CHECK_EQ_INT(e.item, 3);
		memcpy(data + at, save, 4);
	}
	/* counts that do not match the size */
	data[16] ^= 0x40;
	CHECK_EQ_INT(lattice_read_buffer(data, len, &r, &e), ERR_PARSE);
	data[16] ^= 0x40;
	/* NaN coordinate */
	memset(data + 128 + 4, 0xff, 4);
	CHECK_EQ_INT(lattice_read_buffer(data, len, &r, &e), ERR_PARSE);
	CHECK_CONTAINS(e.msg, "non-finite");
	/* bad magic */
	data[0] = 'X';
	CHECK_EQ_INT(lattice_read_buffer(data, len, &r, &e), ERR_PARSE);
	/* the streaming reader reports the same problems */
	{
		struct lattice_stream *st = NULL;
		struct lattice_file_header h;
		char p2[64];
		FILE *g = fopen(tmp_file(p2), "wb");
		REQUIRE(g);
		data[0] = 'I';
		memset(data + 128 + 4, 0, 4);
		/* edge 2's lower node made larger than edge 3's */
		memset(data + 128 + 12 * q->nnodes + 10 * 2, 0x7f, 1);
		fwrite(data, 1, len, g);
		fclose(g);
		REQUIRE_OK(lattice_stream_open(p2, &h, &st, &e), &e);
		{
			struct lattice_source src = lattice_stream_source(st);
			struct lattice_strut s;
			int rc, n = 0;
			while ((rc = src.next(src.ctx, &s, &e)) == 1)
				n++;
			CHECK_EQ_INT(rc, ERR_PARSE);
			CHECK_INT(n, <=, 3);
		}
		lattice_stream_free(st);
		unlink(p2);
	}
	CHECK(r == NULL);
	mem_free(data);
	lattice_free(q);
	unlink(path);
}

static void test_malformed_text(void)
{
	struct err e;
	struct lattice *r = NULL;
	static const char *bad[] = {
		"infilld-lattice 2\nnodes 0\nedges 0\n",
		"infilld-lattice 1\nnodes 2\n0 0 0\n1 1\nedges 0\n",
		"infilld-lattice 1\nnodes 2\n0 0 0\n1 1 1\nedges 1\n0 2 0.5\n",
		"infilld-lattice 1\nnodes 2\n0 0 0\n1 1 1\nedges 1\n0 1 -0.5\n",
		"infilld-lattice 1\nnodes 99999999\n0 0 0\n",
		"infilld-lattice 1\nnodes 2\n0 0 0\n1 1 nan\nedges 0\n",
		"infilld-lattice 1\nnodes 1\n0 0 0\nedges 0\ntrailing\n",
	};
	static const long line[] = {1, 4, 6, 6, 2, 4, 5};
	const char *ok = "infilld-lattice 1\n# comment\nsupport_mm 0.8\nnodes 2\n0 0 0\n\n"
			 "1 2 3 # end\nedges 1\n1 0 0.25\n";

	for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
		CHECK_EQ_INT(lattice_read_buffer(bad[i], strlen(bad[i]), &r, &e), ERR_PARSE);
		CHECK_EQ_INT(e.line, line[i]);
	}
	CHECK(r == NULL);
	REQUIRE_OK(lattice_read_buffer(ok, strlen(ok), &r, &e), &e);
	CHECK_EQ_INT(r->nedges, 1);
	CHECK_NUM(r->support_mm, ==, 0.8);
	CHECK_NUM(r->node[1].z, ==, 3);
	lattice_free(r);
	CHECK_EQ_INT(lattice_file_probe_buffer("infilld-latticeX", 16), LATTICE_FILE_NONE);
	CHECK_EQ_INT(lattice_file_probe_buffer("solid x", 7), LATTICE_FILE_NONE);
}

/* Every allocation of a read can fail: ERR_NOMEM or success, no leak. */
static void test_allocation_failures(void)
{
	struct err e;
	struct buf b;
	struct sink s;
	struct lattice *q = random_lattice(30, 3), *r;
	int seen_nomem = 0;

	buf_init(&b);
	sink_init_buf(&s, &b);
	REQUIRE_OK(lattice_write_text(q, &s, &e), &e);
	for (long n = 1; n < 40; n++) {
		int rc;
		r = NULL;
		mem_fail_after(n);
		rc = lattice_read_buffer(b.data, b.len, &r, &e);
		mem_fail_after(-1);
		CHECK(rc == 0 || rc == ERR_NOMEM);
		seen_nomem += rc == ERR_NOMEM;
		lattice_free(r);
	}
	CHECK_INT(seen_nomem, >, 0);
	buf_fini(&b);
	lattice_free(q);
}

int main(void)
{
	RUN(test_binary_round_trip);
	RUN(test_text_round_trip);
	RUN(test_streaming_writer);
	RUN(test_malformed_binary);
	RUN(test_malformed_text);
	RUN(test_allocation_failures);
	return harness_report();
}
