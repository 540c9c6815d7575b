/* metrics.c - ordered metric record (see metrics.h). */
#include "engine/core/metrics.h"
#include "engine/core/err.h"
#include "engine/core/mem.h"

#include <math.h>
#include <string.h>

void metrics_init(struct metrics *m)
{
	memset(m, 0, sizeof *m);
}

void metrics_fini(struct metrics *m)
{
	for (size_t i = 0; i < m->n; i++) {
		mem_free(m->v[i].key);
		mem_free(m->v[i].str);
	}
	mem_free(m->v);
	memset(m, 0, sizeof *m);
}

const struct metric *metrics_get(const struct metrics *m, const char *key)
{
	for (size_t i = 0; i < m->n; i++)
		if (strcmp(m->v[i].key, key) == 0)
			return &m->v[i];
	return NULL;
}

/* Find or append the slot for key; its old string value is released. */
static struct metric *slot(struct metrics *m, const char *key)
{
	struct metric *x;
	void *arr = m->v;

	for (size_t i = 0; i < m->n; i++) {
		if (strcmp(m->v[i].key, key) == 0) {
			mem_free(m->v[i].str);
			m->v[i].str = NULL;
			return &m->v[i];
		}
	}
	if (strlen(key) > 127 || mem_grow(&arr, &m->cap, m->n + 1, sizeof *m->v))
		return NULL;
	m->v = arr;
	x = &m->v[m->n];
	memset(x, 0, sizeof *x);
	x->key = mem_strdup(key);
	if (!x->key)
		return NULL;
	m->n++;
	return x;
}

int metrics_num(struct metrics *m, const char *key, double v)
{
	struct metric *x = slot(m, key);

	if (!x)
		return ERR_NOMEM;
	x->type = METRIC_NUM;
	x->num = isfinite(v) ? v : NAN;
	return 0;
}

int metrics_int(struct metrics *m, const char *key, long long v)
{
	struct metric *x = slot(m, key);

	if (!x)
		return ERR_NOMEM;
	x->type = METRIC_INT;
	x->ival = v;
	return 0;
}

int metrics_bool(struct metrics *m, const char *key, int v)
{
	struct metric *x = slot(m, key);

	if (!x)
		return ERR_NOMEM;
	x->type = METRIC_BOOL;
	x->ival = v != 0;
	return 0;
}

int metrics_str(struct metrics *m, const char *key, const char *v)
{
	struct metric *x = slot(m, key);

	if (!x)
		return ERR_NOMEM;
	x->type = METRIC_STR;
	x->str = mem_strdup(v ? v : "");
	return x->str ? 0 : ERR_NOMEM;
}

int metrics_append_str(struct metrics *m, const char *key, const char *v)
{
	const struct metric *old = metrics_get(m, key);
	size_t ol = old && old->type == METRIC_STRS && old->str ? strlen(old->str) : 0;
	size_t vl = strlen(v ? v : "");
	long long count = old && old->type == METRIC_STRS ? old->ival : 0;
	char *buf = mem_alloc(ol + 1 + vl + 1), *q;
	struct metric *x;

	if (!buf)
		return ERR_NOMEM;
	q = buf;
	if (count) {
		memcpy(q, old->str, ol);
		q += ol;
		*q++ = '\n';
	}
	for (size_t i = 0; i < vl; i++)
		*q++ = v[i] == '\n' || v[i] == '\r' ? ' ' : v[i];
	*q = 0;
	x = slot(m, key); /* frees the old list */
	if (!x) {
		mem_free(buf);
		return ERR_NOMEM;
	}
	x->type = METRIC_STRS;
	x->str = buf;
	x->ival = count + 1;
	return 0;
}
