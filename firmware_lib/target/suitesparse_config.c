/* The SuiteSparse_config object COLAMD refers to, defined here instead of compiling
 * SuiteSparse_config.c: that file's defaults point at malloc, free and printf. All members null:
 * colamd() takes its workspace from the caller and never allocates, and its optional PRINTF
 * checks printf_func for null, so nothing here links a heap or stdio. */
#include "SuiteSparse_config.h"

struct SuiteSparse_config_struct SuiteSparse_config;
