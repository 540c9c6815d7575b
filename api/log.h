/* log.h - one-line logs on stderr: "2024-05-01T12:00:00.123Z level
 * component: message", for journald or docker logs.  Thread- and
 * process-safe (one write() per line).
 */
#ifndef INFILLD_LOG_H
#define INFILLD_LOG_H

enum log_level { LOG_DEBUG, LOG_INFO, LOG_WARN, LOG_ERROR };

/* Lines below level are dropped (default LOG_INFO; env INFILLD_LOG=debug). */
void log_set_level(enum log_level level);
void log_msg(enum log_level level, const char *component, const char *fmt, ...)
#if defined(__GNUC__)
	__attribute__((format(printf, 3, 4)))
#endif
	;

#endif
