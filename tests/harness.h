/* harness.h - the unit-test harness: typed checks that print both values.
 *
 * Each tests/unit/<module>/test_*.c is one program: its main() calls
 * RUN(fn) for each test function and returns harness_report().  A failed
 * CHECK prints file:line, the expression and both values, marks the test
 * failed and continues; REQUIRE_* return from the test function.
 * Paths: SHARED_DIR is ../shared relative to the repo root (tests run
 * from the repo root); override with INFILLD_SHARED.
 */
#ifndef INFILLD_HARNESS_H
#define INFILLD_HARNESS_H

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* xorshift64 (Marsaglia 13, 7, 17): deterministic test data; *s != 0. */
static inline uint64_t harness_xorshift64(uint64_t *s)
{
	*s ^= *s << 13;
	*s ^= *s >> 7;
	*s ^= *s << 17;
	return *s;
}

static int harness_failed_checks;
static int harness_failed_tests;
static int harness_tests;
static int harness_cur_failed;

#define CHECK(cond)                                                                  \
	do {                                                                         \
		if (!(cond)) {                                                       \
			fprintf(stderr, "%s:%d: CHECK(%s) failed\n", __FILE__, __LINE__, \
				#cond);                                              \
			harness_failed_checks++;                                     \
			harness_cur_failed = 1;                                      \
		}                                                                    \
	} while (0)

#define CHECK_INT(a, op, b)                                                          \
	do {                                                                         \
		long long va_ = (long long)(a), vb_ = (long long)(b);                \
		if (!(va_ op vb_)) {                                                 \
			fprintf(stderr, "%s:%d: CHECK(%s %s %s) failed: %lld vs %lld\n", \
				__FILE__, __LINE__, #a, #op, #b, va_, vb_);          \
			harness_failed_checks++;                                     \
			harness_cur_failed = 1;                                      \
		}                                                                    \
	} while (0)
#define CHECK_EQ_INT(a, b) CHECK_INT(a, ==, b)

#define CHECK_NUM(a, op, b)                                                          \
	do {                                                                         \
		double va_ = (double)(a), vb_ = (double)(b);                         \
		if (!(va_ op vb_)) {                                                 \
			fprintf(stderr, "%s:%d: CHECK(%s %s %s) failed: %.17g vs %.17g\n", \
				__FILE__, __LINE__, #a, #op, #b, va_, vb_);          \
			harness_failed_checks++;                                     \
			harness_cur_failed = 1;                                      \
		}                                                                    \
	} while (0)

/* |a - b| <= tol */
#define CHECK_NEAR(a, b, tol)                                                        \
	do {                                                                         \
		double va_ = (double)(a), vb_ = (double)(b), vt_ = (double)(tol);    \
		if (!(fabs(va_ - vb_) <= vt_)) {                                     \
			fprintf(stderr,                                              \
				"%s:%d: CHECK_NEAR(%s, %s, %s) failed: %.17g vs %.17g " \
				"(diff %.3g)\n",                                     \
				__FILE__, __LINE__, #a, #b, #tol, va_, vb_, va_ - vb_); \
			harness_failed_checks++;                                     \
			harness_cur_failed = 1;                                      \
		}                                                                    \
	} while (0)

/* relative: |a - b| <= rel * |b| */
#define CHECK_REL(a, b, rel)                                                         \
	do {                                                                         \
		double va_ = (double)(a), vb_ = (double)(b), vr_ = (double)(rel);    \
		if (!(fabs(va_ - vb_) <= vr_ * fabs(vb_))) {                         \
			fprintf(stderr,                                              \
				"%s:%d: CHECK_REL(%s, %s, %s) failed: %.17g vs %.17g " \
				"(rel diff %.3g)\n",                                 \
				__FILE__, __LINE__, #a, #b, #rel, va_, vb_,          \
				vb_ != 0 ? (va_ - vb_) / fabs(vb_) : va_ - vb_);     \
			harness_failed_checks++;                                     \
			harness_cur_failed = 1;                                      \
		}                                                                    \
	} while (0)

#define CHECK_STR(a, b)                                                              \
	do {                                                                         \
		const char *sa_ = (a), *sb_ = (b);                                   \
		if (!sa_ || !sb_ || strcmp(sa_, sb_) != 0) {                         \
			fprintf(stderr, "%s:%d: CHECK_STR(%s, %s) failed: \"%s\" vs \"%s\"\n", \
				__FILE__, __LINE__, #a, #b, sa_ ? sa_ : "(null)",    \
				sb_ ? sb_ : "(null)");                               \
			harness_failed_checks++;                                     \
			harness_cur_failed = 1;                                      \
		}                                                                    \
	} while (0)

/* substring */
#define CHECK_CONTAINS(hay, needle)                                                  \
	do {                                                                         \
		const char *sh_ = (hay), *sn_ = (needle);                            \
		if (!sh_ || !sn_ || !strstr(sh_, sn_)) {                             \
			fprintf(stderr, "%s:%d: \"%s\" does not contain \"%s\"\n",   \
				__FILE__, __LINE__, sh_ ? sh_ : "(null)",            \
				sn_ ? sn_ : "(null)");                               \
			harness_failed_checks++;                                     \
			harness_cur_failed = 1;                                      \
		}                                                                    \
	} while (0)

/* Stop the current test function when cond fails (e.g. NULL results). */
#define REQUIRE(cond)                                                                \
	do {                                                                         \
		if (!(cond)) {                                                       \
			fprintf(stderr, "%s:%d: REQUIRE(%s) failed\n", __FILE__,     \
				__LINE__, #cond);                                    \
			harness_failed_checks++;                                     \
			harness_cur_failed = 1;                                      \
			return;                                                      \
		}                                                                    \
	} while (0)

/* Require an engine call to return 0, printing its error record. */
#define REQUIRE_OK(call, errp)                                                       \
	do {                                                                         \
		int rc_ = (call);                                                    \
		if (rc_ != 0) {                                                      \
			fprintf(stderr, "%s:%d: %s returned %d: %s\n", __FILE__,     \
				__LINE__, #call, rc_, (errp)->msg);                  \
			harness_failed_checks++;                                     \
			harness_cur_failed = 1;                                      \
			return;                                                      \
		}                                                                    \
	} while (0)

#define RUN(fn)                                                                      \
	do {                                                                         \
		harness_cur_failed = 0;                                              \
		harness_tests++;                                                     \
		fn();                                                                \
		if (harness_cur_failed) {                                            \
			harness_failed_tests++;                                      \
			fprintf(stderr, "FAIL %s\n", #fn);                           \
		} else if (getenv("HARNESS_VERBOSE")) {                              \
			fprintf(stderr, "ok   %s\n", #fn);                           \
		}                                                                    \
	} while (0)

static inline int harness_report(void)
{
	fprintf(stderr, "%d tests, %d failed (%d failed checks)\n", harness_tests,
		harness_failed_tests, harness_failed_checks);
	return harness_failed_tests ? 1 : 0;
}

/* Path of a file under ../shared (meshes/...), in a static buffer. */
static inline const char *shared_path(const char *rel)
{
	static char buf[4][1024];
	static int k;
	const char *base = getenv("INFILLD_SHARED");
	char *b = buf[k++ & 3];

	snprintf(b, sizeof buf[0], "%s/%s", base ? base : "../shared", rel);
	return b;
}

#endif
