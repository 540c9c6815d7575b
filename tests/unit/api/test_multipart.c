/* test_multipart.c - the streaming multipart/form-data parser: parts and
 * their data survive any split of the body into pieces (every split
 * point, and byte by byte), delimiter look-alikes stay data, malformed
 * bodies are refused. */
#include "harness.h"

#include "api/multipart.h"

struct got {
	char names[4][32], files[4][32];
	char data[4][256];
	size_t len[4];
	int parts;
};

static int on_begin(void *ctx, const char *name, const char *filename)
{
	struct got *g = ctx;

	if (g->parts >= 4)
		return -1;
	snprintf(g->names[g->parts], sizeof g->names[0], "%s", name);
	snprintf(g->files[g->parts], sizeof g->files[0], "%s", filename);
	g->parts++;
	return 0;
}

static int on_data(void *ctx, const void *p, size_t len)
{
	struct got *g = ctx;
	int i = g->parts - 1;

	if (g->len[i] + len > sizeof g->data[0])
		return -1;
	memcpy(g->data[i] + g->len[i], p, len);
	g->len[i] += len;
	return 0;
}

static const char body[] =
	"preamble to ignore\r\n"
	"--XyZ\r\n"
	"Content-Disposition: form-data; name=\"sha256\"\r\n\r\n"
	"abc\r\n"
	"--XyZ\r\n"
	"Content-Disposition: form-data; name=\"file\"; filename=\"part.stl\"\r\n"
	"Content-Type: application/octet-stream\r\n\r\n"
	"solid x\r\n--XyQ not a delimiter\r\n--Xy\r\r\n\r\nend\r\n"
	"--XyZ--\r\nepilogue";

static void check_got(const struct got *g)
{
	static const char file_data[] = "solid x\r\n--XyQ not a delimiter\r\n--Xy\r\r\n\r\nend";

	CHECK_EQ_INT(g->parts, 2);
	CHECK_STR(g->names[0], "sha256");
	CHECK_STR(g->names[1], "file");
	CHECK_STR(g->files[1], "part.stl");
	CHECK_EQ_INT(g->len[0], 3);
	CHECK(!memcmp(g->data[0], "abc", 3));
	CHECK_EQ_INT(g->len[1], sizeof file_data - 1);
	CHECK(!memcmp(g->data[1], file_data, sizeof file_data - 1));
}

static void test_every_split(void)
{
	size_t n = sizeof body - 1;

	for (size_t cut = 0; cut <= n; cut++) {
		struct multipart m;
		struct got g;
		struct multipart_cb cb = {on_begin, on_data, &g};

		memset(&g, 0, sizeof g);
		REQUIRE(multipart_init(&m, "multipart/form-data; boundary=XyZ", &cb) == 0);
		CHECK_EQ_INT(multipart_feed(&m, body, cut), 0);
		CHECK_EQ_INT(multipart_feed(&m, body + cut, n - cut), 0);
		CHECK_EQ_INT(multipart_finish(&m), 0);
		check_got(&g);
		if (harness_cur_failed) {
			fprintf(stderr, "split at %zu\n", cut);
			return;
		}
	}
}

static void test_byte_by_byte(void)
{
	struct multipart m;
	struct got g;
	struct multipart_cb cb = {on_begin, on_data, &g};

	memset(&g, 0, sizeof g);
	REQUIRE(multipart_init(&m, "multipart/form-data; boundary=\"XyZ\"", &cb) == 0);
	for (size_t i = 0; i < sizeof body - 1; i++)
		REQUIRE(multipart_feed(&m, body + i, 1) == 0);
	CHECK_EQ_INT(multipart_finish(&m), 0);
	check_got(&g);
}

static void test_malformed(void)
{
	struct multipart m;
	struct got g;
	struct multipart_cb cb = {on_begin, on_data, &g};
	char hdr[3000];

	CHECK(multipart_init(&m, "multipart/form-data", &cb) != 0);
	CHECK(multipart_init(&m, "text/plain; boundary=x", &cb) != 0);
	CHECK(multipart_init(&m, "multipart/form-data; boundary=", &cb) != 0);
	memset(&g, 0, sizeof g);
	REQUIRE(multipart_init(&m, "multipart/form-data; boundary=b", &cb) == 0);
	CHECK_EQ_INT(multipart_feed(&m, "--b\r\nContent-Type: x\r\n\r\ndata", 30), -1);
	CHECK_CONTAINS(m.error, "name");
	memset(&g, 0, sizeof g);
	REQUIRE(multipart_init(&m, "multipart/form-data; boundary=b", &cb) == 0);
	CHECK_EQ_INT(multipart_feed(&m, "--b\r\nContent-Disposition: form-data; name=\"f\"\r\n\r\nab", 50), 0);
	CHECK_EQ_INT(multipart_finish(&m), -1); /* no closing delimiter */
	memset(&g, 0, sizeof g);
	REQUIRE(multipart_init(&m, "multipart/form-data; boundary=b", &cb) == 0);
	memset(hdr, 'a', sizeof hdr);
	memcpy(hdr, "--b\r\n", 5);
	CHECK_EQ_INT(multipart_feed(&m, hdr, sizeof hdr), -1); /* endless part headers */
	memset(&g, 0, sizeof g);
	REQUIRE(multipart_init(&m, "multipart/form-data; boundary=b", &cb) == 0);
	CHECK_EQ_INT(multipart_feed(&m, "--bXX", 5), -1);
}

int main(void)
{
	RUN(test_every_split);
	RUN(test_byte_by_byte);
	RUN(test_malformed);
	return harness_report();
}
