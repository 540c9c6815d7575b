/* commands.h - the infilld binary's sub-commands (one file each). */
#ifndef INFILLD_COMMANDS_H
#define INFILLD_COMMANDS_H

/* Each takes the arguments after the command name (argv[0] = command)
 * and returns the process exit status: 0 ok, 1 failure, 2 usage. */
int cmd_run(int argc, char **argv);     /* cli_run.c */
int cmd_analyze(int argc, char **argv); /* cli_run.c */
int cmd_engines(int argc, char **argv); /* cli_run.c */

#endif
