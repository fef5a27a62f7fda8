/* Filter plugins: a 2D pixel reconstruction kernel. The film splats every
 * sample into each pixel within the radius, weighted by eval(dx, dy), and
 * divides by the summed weights. */
#ifndef RTK_FILTER_H
#define RTK_FILTER_H

#include <rtk/plugin.h>

RTK_EXTERN_C_BEGIN

/* Function table of a filter. */
typedef struct rtk_filter_fns {
    uint32_t size; /* sizeof(rtk_filter_fns) */
    /* Makes an instance from validated params. [main thread] */
    rtk_status (*create)(const rtk_params *params, void **state);
    /* Half-width of the square support, in pixels (> 0). [any thread] */
    float (*radius)(const void *state);
    /* Weight at offset (dx, dy) from the pixel centre; 0 outside the
     * support, may be negative. [any thread, concurrently] */
    float (*eval)(const void *state, float dx, float dy);
    /* Closed-form integral of eval over the support (checked by conform). */
    double (*integral)(const void *state);
    /* Frees the instance. [main thread] */
    void (*destroy)(void *state);
} rtk_filter_fns;

RTK_EXTERN_C_END

#endif
