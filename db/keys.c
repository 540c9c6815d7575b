/* keys.c - API keys and digests shared by the database backends (see
 * db_ops.h): random keys from getrandom(), SHA-256 from nettle, and a
 * constant-time comparison so a key's hash cannot be found byte by byte
 * from response times.
 */
#include "db/db_ops.h"
#include "engine/core/err.h"

#include <errno.h>
#include <nettle/memops.h>
#include <nettle/sha2.h>
#include <stdio.h>
#include <string.h>
#include <sys/random.h>

#define KEY_SECRET_LEN 32 /* base32: 160 bits */

static const char key_alphabet[] = "abcdefghijklmnopqrstuvwxyz234567";

void db_sha256_hex(const unsigned char digest[32], char hex[SHA256_HEX_LEN + 1])
{
	static const char hx[] = "0123456789abcdef";

	for (int i = 0; i < 32; i++) {
		hex[2 * i] = hx[digest[i] >> 4];
		hex[2 * i + 1] = hx[digest[i] & 15];
	}
	hex[SHA256_HEX_LEN] = '\0';
}

void db_key_hash(const char *key, unsigned char hash[DB_KEY_HASH_LEN])
{
	struct sha256_ctx c;

	sha256_init(&c);
	sha256_update(&c, strlen(key), (const uint8_t *)key);
	sha256_digest(&c, DB_KEY_HASH_LEN, hash);
}

int db_key_hash_eq(const void *stored, size_t len, const unsigned char hash[DB_KEY_HASH_LEN])
{
	return stored && len == DB_KEY_HASH_LEN && memeql_sec(stored, hash, DB_KEY_HASH_LEN);
}

/* n random characters of key_alphabet into buf, NUL-terminated. */
static int random_chars(char *buf, int n, struct err *e)
{
	unsigned char rnd[64];
	size_t got = 0;

	while (got < (size_t)n) {
		ssize_t r = getrandom(rnd + got, (size_t)n - got, 0);
		if (r < 0) {
			if (errno == EINTR)
				continue;
			return ERR_SET(e, ERR_IO, "getrandom: %s", strerror(errno));
		}
		got += (size_t)r;
	}
	for (int i = 0; i < n; i++)
		buf[i] = key_alphabet[rnd[i] & 31];
	buf[n] = '\0';
	return 0;
}

int db_key_make(const char *kind, char *key, char key_id[DB_KEY_ID_LEN + 1],
		unsigned char hash[DB_KEY_HASH_LEN], struct err *e)
{
	char secret[KEY_SECRET_LEN + 1];
	int rc = random_chars(key_id, DB_KEY_ID_LEN, e);

	if (!rc)
		rc = random_chars(secret, KEY_SECRET_LEN, e);
	if (rc)
		return rc;
	snprintf(key, API_KEY_MAX, "%s_%s_%s", kind, key_id, secret);
	db_key_hash(key, hash);
	return 0;
}

int db_key_parse(const char *key, const char *kind, char key_id[DB_KEY_ID_LEN + 1])
{
	size_t kl = strlen(kind);

	if (!key || strlen(key) != kl + 1 + DB_KEY_ID_LEN + 1 + KEY_SECRET_LEN)
		return -1;
	if (strncmp(key, kind, kl) || key[kl] != '_' || key[kl + 1 + DB_KEY_ID_LEN] != '_')
		return -1;
	for (int i = 0; i < DB_KEY_ID_LEN; i++) {
		char c = key[kl + 1 + (size_t)i];
		if (!c || !strchr(key_alphabet, c))
			return -1;
		key_id[i] = c;
	}
	key_id[DB_KEY_ID_LEN] = '\0';
	return 0;
}
