/* metrics.h - an ordered record of a run's measured figures.
 *
 * Engines and writers record figures under dotted keys
 * ("layers", "lattice.gamma_raw", "lattice.seconds.tetgen"); api/ turns
 * the record into nested JSON (engine/ knows no JSON).  Setting a key
 * again replaces its value and keeps its position.
 */
#ifndef INFILLD_METRICS_H
#define INFILLD_METRICS_H

#include <stddef.h>

enum metric_type { METRIC_NUM, METRIC_INT, METRIC_BOOL, METRIC_STR, METRIC_STRS };

struct metric {
	char *key; /* owned */
	enum metric_type type;
	double num;     /* METRIC_NUM (non-finite values are stored as NaN -> JSON null) */
	long long ival; /* METRIC_INT, METRIC_BOOL (0/1) */
	char *str;      /* METRIC_STR, owned; METRIC_STRS: the list's strings joined
			 * by '\n' (none holds one), ival of them */
};

struct metrics {
	struct metric *v;
	size_t n, cap;
};

void metrics_init(struct metrics *m);
void metrics_fini(struct metrics *m);

/* Each returns 0 or ERR_NOMEM.  key: dotted path, at most 127 chars. */
int metrics_num(struct metrics *m, const char *key, double v);
int metrics_int(struct metrics *m, const char *key, long long v);
int metrics_bool(struct metrics *m, const char *key, int v);
int metrics_str(struct metrics *m, const char *key, const char *v);
/* Append v to the list of strings under key (a JSON array of strings;
 * created on first use, replacing a value of another type).  Newlines in v
 * become spaces. */
int metrics_append_str(struct metrics *m, const char *key, const char *v);

/* The entry for key, or NULL.  Borrowed: valid until the next metrics_*
 * call that adds a key (the array may move). */
const struct metric *metrics_get(const struct metrics *m, const char *key);

#endif
