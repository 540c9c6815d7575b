/* main.c - the infilld binary: one job from the shell, or the service.
 * Dispatches to the sub-commands of commands.h. */
#include <stdio.h>
#include <string.h>

#include "engine/engine.h"
#include "service/commands.h"
#include "service/config.h"

struct command {
	const char *name;
	int (*fn)(int argc, char **argv);
	const char *usage;
};

static const struct command commands[] = {
	{"run", cmd_run,
	 "run MESH -o OUT [--engine NAME] [--format sl1|sl1s|zip|gcode|stl|obj]\n"
	 "              [--printer NAME] [--set KEY=VALUE]... [--params FILE.json]\n"
	 "              [--loads FILE.json] [--metrics FILE.json] [--threads N] [--quiet]"},
	{"analyze", cmd_analyze, "analyze MESH [--set KEY=VALUE]...   (JSON report on stdout)"},
	{"engines", cmd_engines, "engines                              (JSON: engines and parameters)"},
	{"verify", cmd_verify,
	 "verify ARCHIVE [--alpha-deg A] [--layer-mm H] [--pixel-mm P] [--tolerance-px T]\n"
	 "       [--solid SOLID] [--strict | --strict-all] [--threads N]\n"
	 "              (JSON: interior overhangs, floating islands, walls of an SL1/zip stack)"},
	{"fea", cmd_fea,
	 "fea INPUT [--loads FILE.json] [--printer NAME] [--set KEY=VALUE]... [--out-vtk FILE.vti]\n"
	 "              [--threads N] [--quiet]   (JSON: stiffness of a mesh or a layer archive\n"
	 "              under a load case; docs/fea_cli.md)"},
	{"serve", cmd_serve, NULL}, /* usage from config_usage() */
	{"tenant", cmd_tenant,
	 "tenant add NAME [--max-jobs N] [--max-upload-mb N] [--quota-gb N] [LOCATION]\n"
	 "              tenant list | key-rotate NAME | remove NAME [LOCATION]\n"
	 "              (LOCATION: [--data DIR] [--db URL] [--store DIR], as serve takes them)"},
	{"admin-key", cmd_admin_key, "admin-key [--data DIR] [--db URL]    (new admin key, shown once)"},
	{"fsck", cmd_fsck,
	 "fsck [LOCATION] [--quarantine]       (check artifacts against their recorded SHA-256;\n"
	 "              exit 1 when any is damaged or missing; --quarantine moves damaged ones\n"
	 "              to STORE/quarantine/ and their downloads answer 410)"},
	{"worker", cmd_worker,
	 "worker --db URL --store DIR [--data DIR] [--slots N] [serve's job options]\n"
	 "              (claims and runs jobs, no HTTP: the workers of a cluster)"},
	{"migrate-db", cmd_migrate_db,
	 "migrate-db --from URL --to URL       (copy every row into an empty database, e.g.\n"
	 "              sqlite:DATA/infilld.db to postgresql://...; docs/operations.md)"},
	/* Internal: started by serve, not listed. */
	{"sandbox", cmd_sandbox, ""},
};

static void usage(FILE *f)
{
	fprintf(f, "infilld %s - interiors for 3D-printed parts\n\nusage:\n", INFILLD_VERSION);
	for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
		if (!commands[i].usage)
			fprintf(f, "  infilld %s\n", config_usage());
		else if (commands[i].usage[0]) /* "" = internal, not listed */
			fprintf(f, "  infilld %s\n", commands[i].usage);
	fprintf(f, "\nSee README.md and docs/ for parameters and formats.\n");
}

int main(int argc, char **argv)
{
	if (argc < 2) {
		usage(stderr);
		return 2;
	}
	if (!strcmp(argv[1], "-h") || !strcmp(argv[1], "--help") || !strcmp(argv[1], "help")) {
		usage(stdout);
		return 0;
	}
	if (!strcmp(argv[1], "--version") || !strcmp(argv[1], "version")) {
		printf("infilld %s\n", INFILLD_VERSION);
		return 0;
	}
	for (size_t i = 0; i < sizeof commands / sizeof commands[0]; i++)
		if (!strcmp(argv[1], commands[i].name))
			return commands[i].fn(argc - 1, argv + 1);
	fprintf(stderr, "infilld: unknown command '%s'\n", argv[1]);
	usage(stderr);
	return 2;
}
