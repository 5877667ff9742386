/* prismfarm upgrade: a pbrt-v3 scene file rewritten for pbrt-v4, as `pbrt --upgrade` does
 * (scenefile/pbrt_upgrade.h); each rewrite is listed on stderr with its file:line. */
#include "commands.h"

#include "cli_args.h"
#include "files.h"
#include "pbrt_upgrade.h"
#include "warnings.h"

#include <stdio.h>
#include <stdlib.h>

static void usage(FILE *out, const cli_opt_t *opts)
{
    fprintf(
        out,
        "usage: prismfarm upgrade OLD.pbrt [-o NEW.pbrt]\n"
        "\n"
        "Rewrites a pbrt-v3 scene file as pbrt-v4 reads it, as pbrt-v4's `pbrt --upgrade`\n"
        "does: WorldEnd dropped, the v3 materials (uber, plastic, substrate, glass, metal,\n"
        "mirror, matte, translucent, ...) as their v4 counterparts, \"color\" textures, Film\n"
        "\"image\", v3 samplers, filter widths, light scales and more (docs/compatibility.md).\n"
        "Statements that need no change are copied as they are. Each rewrite is listed on\n"
        "stderr as file:line. Included files are not followed: upgrade each one.\n");
    cli_args_help(out, opts);
    fprintf(
        out,
        "\nexit status: 0 written, 1 the file cannot be read or upgraded, 2 bad command line\n");
}

int cmd_upgrade(int argc, char **argv)
{
    const char *out_path = NULL;
    int quiet = 0;
    const cli_opt_t opts[] = {
        {.name = "output",
         .letter = 'o',
         .kind = CLI_STRING,
         .dst = &out_path,
         .arg = "NEW.pbrt",
         .help = "write here (atomically) instead of stdout"},
        CLI_OPT_QUIET(.dst = &quiet, .help = "do not list the rewrites"),
        CLI_OPT_HELP,
        {0},
    };
    int first;
    const cli_cmd_t cmd = {.name = "upgrade", .opts = opts, .usage = usage};
    int parsed = cli_args_parse(&cmd, argc, argv, &first);
    if (parsed != CLI_ARGS_GO)
        return parsed;
    if (argc - first != 1) {
        fprintf(stderr, "prismfarm upgrade: %s\n",
                first == argc ? "no scene given" : "one file at a time");
        usage(stderr, opts);
        return 2;
    }
    const char *path = argv[first];
    err_t err = {{0}};
    uint8_t *data = NULL;
    size_t size = 0, out_len = 0;
    warnings_t *w = warnings_new(&err);
    char *text = NULL;
    int rc = 1;
    if (!w || files_read(path, (size_t)1 << 31, &data, &size, &err) ||
        !(text = pbrt_upgrade_text(path, (const char *)data, size, w, &out_len, &err))) {
        fprintf(stderr, "prismfarm upgrade: %s\n", err.msg);
        goto done;
    }
    if (!quiet)
        for (size_t i = 0; i < warnings_count(w); i++)
            fprintf(stderr, "%s\n", warnings_at(w, i));
    if (out_path) {
        if (files_write_atomic(out_path, text, out_len, false, &err)) {
            fprintf(stderr, "prismfarm upgrade: %s\n", err.msg);
            goto done;
        }
    } else if (fwrite(text, 1, out_len, stdout) != out_len || fflush(stdout) != 0) {
        fprintf(stderr, "prismfarm upgrade: cannot write the upgraded text\n");
        goto done;
    }
    rc = 0;
done:
    free(text);
    free(data);
    warnings_destroy(&w);
    return rc;
}
