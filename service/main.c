/* main.c - the infilld binary: CLI entry point (service/cli.c holds the
 * commands once they exist). */
#include <stdio.h>

int main(int argc, char **argv)
{
	(void)argc;
	(void)argv;
	fputs("usage: infilld run MESH -o OUT [options]\n", stderr);
	return 2;
}
