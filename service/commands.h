/* commands.h - the infilld binary's sub-commands (one file each). */
#ifndef INFILLD_COMMANDS_H
#define INFILLD_COMMANDS_H

/* Each takes the arguments after the command name (argv[0] = command)
 * and returns the process exit status: 0 ok, 1 failure, 2 usage. */
int cmd_run(int argc, char **argv);     /* cli_run.c */
int cmd_analyze(int argc, char **argv); /* cli_run.c */
int cmd_engines(int argc, char **argv); /* cli_run.c */
int cmd_verify(int argc, char **argv);  /* cli_verify.c */
int cmd_fea(int argc, char **argv);     /* cli_fea.c */
int cmd_serve(int argc, char **argv);     /* serve.c */
int cmd_worker(int argc, char **argv);    /* worker.c (cluster workers; serve's children) */
int cmd_migrate_db(int argc, char **argv); /* migrate_cmd.c */
int cmd_sandbox(int argc, char **argv);   /* sandbox.c (started by serve) */
int cmd_tenant(int argc, char **argv);    /* tenant_cmd.c */
int cmd_admin_key(int argc, char **argv); /* tenant_cmd.c */
int cmd_fsck(int argc, char **argv);      /* fsck_cmd.c */

struct err;
/* Read a JSON load-case file (docs/fea_cli.md) into the FEA engine's text
 * form (api_loads_text); *text: caller frees with mem_free().  0, ERR_PARSE
 * (bad JSON, with its line) or ERR_PARAM naming the JSON path, the file
 * name in the message.  cli_fea.c; `infilld fea` and `infilld run`. */
int cmd_loads_read(const char *path, char **text, struct err *e);

/* A --threads value: the whole number in s when it lies in 1..max, else
 * 0 (the caller names the usage error).  cli_run.c; `infilld run`, `fea`
 * and `verify`. */
int cmd_threads_arg(const char *s, int max);

struct metrics;
/* A run's "warnings" list (docs/metrics.md), one line each on stderr
 * (`infilld: warning: ...`).  cli_run.c; `infilld run` and `infilld fea`. */
void cmd_print_warnings(const struct metrics *m);

#endif
