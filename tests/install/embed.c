/* A program that embeds librtk through <rtk/host.h>, built by
 * tests/install against the installed library with pkg-config alone:
 * lists where the box filter was found, then renders CONFIG to OUTPUT.
 * usage: embed CONFIG OUTPUT */
#include <rtk/host.h>

#include <stdio.h>
#include <string.h>

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: %s CONFIG OUTPUT\n", argv[0]);
        return 2;
    }
    rtk_registry *registry = NULL;
    const rtk_plugin *box = NULL;
    if (rtk_registry_create(&registry) != RTK_OK ||
        rtk_registry_find(registry, RTK_KIND_FILTER, "box", &box) != RTK_OK) {
        fprintf(stderr, "embed: %s\n", rtk_error_message());
        rtk_registry_destroy(registry);
        return 1;
    }
    for (size_t i = 0; i < rtk_registry_count(registry); i++) {
        const rtk_plugin_info *info = rtk_registry_at(registry, i);
        if (info->plugin == box)
            printf("box: %s\n", info->path);
    }
    char output[4096];
    snprintf(output, sizeof output, "film.output=%s", argv[2]);
    const char *overrides[] = {output, "cache=off"};
    rtk_config_options options = {.size = sizeof options, .overrides = overrides, .override_count = 2};
    rtk_config *config = NULL;
    rtk_render_options render = {.size = sizeof render, .quiet = 1};
    rtk_render_report report = {.size = sizeof report};
    rtk_status st = rtk_config_load(argv[1], registry, &options, &config);
    if (st == RTK_OK)
        st = rtk_render(config, &render, &report);
    if (st == RTK_OK)
        printf("rendered %ux%u to %s\n", report.width, report.height, report.output);
    else
        fprintf(stderr, "embed: %s\n", rtk_error_message());
    rtk_config_destroy(config);
    rtk_registry_destroy(registry);
    return st == RTK_OK ? 0 : 1;
}
