/* trioctd: the collision-query daemon. Everything but reading the command line lives in
 * libtrioct_service (options.c, daemon.c), where the tests run it too. */
#include <stdio.h>

#include "daemon.h"
#include "log.h"
#include "options.h"

int main(int argc, char **argv)
{
    daemon_options opt;
    scene sc;
    char err[2048];

    log_init();
    switch (options_load(&opt, argc, argv, &sc, err, sizeof err)) {
    case OPTIONS_RUN:
        break;
    case OPTIONS_HELP:
        options_usage(stdout, argv[0]);
        return 0;
    case OPTIONS_VERSION:
        printf("trioctd %s\n", TRIOCT_VERSION);
        return 0;
    case OPTIONS_ERROR:
        fprintf(stderr, "trioctd: %s\n", err);
        fprintf(stderr, "Try '%s --help'.\n", argv[0]);
        return 2;
    }
    return daemon_run(&opt, &sc);
}
