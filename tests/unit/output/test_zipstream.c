/* test_zipstream.c - the streaming zip layer on its own: entries read
 * back by Python's zipfile (CRCs, stored method, data descriptors), the
 * Zip64 end records past 65,535 entries, sink failures, abandonment.
 */
#include "engine/core/err.h"
#include "engine/core/sink.h"
#include "engine/output/resin/resin.h"
#include "harness.h"
#include "sl1_fixture.h"

/* Run an inline Python check on path; its exit status. */
static int py_check(const char *path, const char *code)
{
	char cmd[4096];
	int rc;

	snprintf(cmd, sizeof cmd, "python3 -c \"import sys, zipfile\n%s\" '%s'", code, path);
	rc = system(cmd);
	return rc == -1 ? -1 : WEXITSTATUS(rc);
}

static void test_entries_read_back(void)
{
	const char *path = fixture_path("plain.zip");
	struct out_zip *z;
	struct sink s;
	struct err e;
	unsigned char big[200000];
	int fd;

	for (size_t i = 0; i < sizeof big; i++)
		big[i] = (unsigned char)(i * 31 + (i >> 9));
	REQUIRE(fixture_open_file(path, &s, &fd) == 0);
	err_clear(&e);
	REQUIRE_OK(out_zip_new(&s, 1700000000, &z, &e), &e);
	REQUIRE_OK(out_zip_add(z, "a.txt", "hello\n", 6, &e), &e);
	REQUIRE_OK(out_zip_add(z, "dir/empty", "", 0, &e), &e);
	REQUIRE_OK(out_zip_add(z, "big.bin", big, sizeof big, &e), &e);
	CHECK_EQ_INT(out_zip_entries(z), 3);
	REQUIRE_OK(out_zip_close(z, &e), &e);
	out_zip_free(z);
	close(fd);
	CHECK_EQ_INT(py_check(path,
			      "z = zipfile.ZipFile(sys.argv[1])\n"
			      "assert z.testzip() is None\n"
			      "assert z.namelist() == ['a.txt', 'dir/empty', 'big.bin'], z.namelist()\n"
			      "assert z.read('a.txt') == b'hello\\n'\n"
			      "assert z.read('dir/empty') == b''\n"
			      "b = z.read('big.bin')\n"
			      "assert b == bytes((i * 31 + (i >> 9)) & 255 for i in range(200000))\n"
			      "for i in z.infolist():\n"
			      "    assert i.compress_type == zipfile.ZIP_STORED, i\n"
			      "    assert i.flag_bits & 8, 'no data descriptor'\n"),
		     0);
	remove(path);
}

/* More entries than the classic end record holds: Zip64 end records. */
static void test_zip64_entry_count(void)
{
	const char *path = fixture_path("many.zip");
	struct out_zip *z;
	struct sink s;
	struct err e;
	char name[32];
	int fd, n = 70000;

	REQUIRE(fixture_open_file(path, &s, &fd) == 0);
	err_clear(&e);
	REQUIRE_OK(out_zip_new(&s, 1700000000, &z, &e), &e);
	for (int i = 0; i < n; i++) {
		snprintf(name, sizeof name, "%d.png", i + 1);
		REQUIRE_OK(out_zip_add(z, name, name, strlen(name), &e), &e);
	}
	REQUIRE_OK(out_zip_close(z, &e), &e);
	out_zip_free(z);
	close(fd);
	CHECK_EQ_INT(py_check(path, "z = zipfile.ZipFile(sys.argv[1])\n"
				    "n = z.namelist()\n"
				    "assert len(n) == 70000, len(n)\n"
				    "assert z.read('69999.png') == b'69999.png'\n"
				    "d = open(sys.argv[1], 'rb').read()\n"
				    "assert b'PK\\x06\\x06' in d[-200:], 'no zip64 end record'\n"),
		     0);
	remove(path);
}

struct fail_after {
	uint64_t budget;
	int calls;
};

static int fail_write(void *ctx, const void *buf, size_t len, struct err *e)
{
	struct fail_after *f = ctx;
	(void)buf;
	f->calls++;
	if (len > f->budget)
		return ERR_SET(e, ERR_IO, "write failed: No space left on device");
	f->budget -= len;
	return 0;
}

/* The sink's error comes back as is, sticks, and close reports it. */
static void test_sink_failure(void)
{
	struct fail_after f = {100000, 0};
	struct out_zip *z;
	struct sink s;
	struct err e;
	static unsigned char block[30000];
	int rc = 0, i;

	memset(&s, 0, sizeof s);
	s.write = fail_write;
	s.ctx = &f;
	err_clear(&e);
	REQUIRE_OK(out_zip_new(&s, 0, &z, &e), &e);
	for (i = 0; i < 20 && !rc; i++)
		rc = out_zip_add(z, "x.bin", block, sizeof block, &e);
	CHECK_EQ_INT(rc, ERR_IO);
	CHECK_CONTAINS(e.msg, "No space left");
	CHECK(i < 20);
	err_clear(&e);
	CHECK_EQ_INT(out_zip_add(z, "y.bin", "y", 1, &e), ERR_IO);
	CHECK_CONTAINS(e.msg, "No space left");
	CHECK_EQ_INT(out_zip_close(z, &e), ERR_IO);
	out_zip_free(z);
}

/* Freed before close: nothing more reaches the sink. */
static void test_abandon_writes_nothing(void)
{
	struct buf b;
	struct sink s;
	struct out_zip *z;
	struct err e;
	size_t before;

	buf_init(&b);
	sink_init_buf(&s, &b);
	err_clear(&e);
	REQUIRE_OK(out_zip_new(&s, 0, &z, &e), &e);
	REQUIRE_OK(out_zip_add(z, "a", "abc", 3, &e), &e);
	before = b.len; /* still buffered in libarchive's block: 0 */
	out_zip_free(z);
	CHECK_EQ_INT(b.len, before);
	buf_fini(&b);
}

int main(void)
{
	RUN(test_entries_read_back);
	RUN(test_zip64_entry_count);
	RUN(test_sink_failure);
	RUN(test_abandon_writes_nothing);
	return harness_report();
}
