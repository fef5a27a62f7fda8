/* Shared basics of the rtk SDK: export macro, status codes, extern "C". */
#ifndef RTK_COMMON_H
#define RTK_COMMON_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
#define RTK_EXTERN_C_BEGIN extern "C" {
#define RTK_EXTERN_C_END }
#else
#define RTK_EXTERN_C_BEGIN
#define RTK_EXTERN_C_END
#endif

/* Marks a symbol that crosses the library or plugin boundary. */
#define RTK_EXPORT __attribute__((visibility("default")))
/* Functions of librtk: exported from the kernel, called by plugins and hosts. */
#define RTK_API RTK_EXPORT

#if defined(__GNUC__)
#define RTK_PRINTF(fmt, args) __attribute__((format(printf, fmt, args)))
#else
#define RTK_PRINTF(fmt, args)
#endif

/* Code that CUDA shares: RTK_HD marks a function nvcc compiles for host
 * and device (empty in C); the SDK's inline helpers are RTK_SDK_INLINE. */
#if defined(__CUDACC__)
#define RTK_HD __host__ __device__
#else
#define RTK_HD
#endif
#define RTK_SDK_INLINE RTK_HD static inline
/* Shared code that must inline into its caller (a function passed by
 * pointer then becomes a direct call). */
#if defined(__CUDACC__)
#define RTK_HD_INLINE __host__ __device__ __forceinline__
#else
#define RTK_HD_INLINE inline __attribute__((always_inline))
#endif

/* Result of every fallible call; the message is in rtk_error_message(). */
typedef enum rtk_status {
    RTK_OK = 0,
    RTK_ERR_INVALID = 1,    /* bad argument or bad input data */
    RTK_ERR_IO = 2,         /* file missing, unreadable or unwritable */
    RTK_ERR_PARSE = 3,      /* malformed file */
    RTK_ERR_NOMEM = 4,      /* allocation failed or input too large */
    RTK_ERR_PLUGIN = 5,     /* plugin missing, refused or misbehaving */
    RTK_ERR_UNSUPPORTED = 6 /* valid request this build cannot serve */
} rtk_status;

#endif
