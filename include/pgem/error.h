/** @file
 * pgem error codes: one enum of negative values and a function that names each. */
#ifndef PGEM_ERROR_H
#define PGEM_ERROR_H

#ifdef __cplusplus
extern "C" {
#endif

/** Every call of the core that can fail returns one of these (0 = success), and only these. A
 * failed call changes nothing in the graph; pgem_last_error() on the instance says which input
 * was wrong. -17 and -18 are not the core's: they are lib/io's PGEM_ERR_IO and PGEM_ERR_PARSE
 * (pgem/io.h), which kept the values they had here. */
typedef enum pgem_error {
    PGEM_OK = 0,
    PGEM_ERR_INVALID_ARGUMENT = -1,  /**< NULL pointer or out-of-range argument */
    PGEM_ERR_CONFIG = -2,            /**< configuration field out of range */
    PGEM_ERR_BUFFER_TOO_SMALL = -3,  /**< caller's block smaller than pgem_memory_size() */
    PGEM_ERR_CAPACITY = -4,          /**< max_poses or max_edges reached */
    PGEM_ERR_DUPLICATE_ID = -5,      /**< a pose with this id already exists */
    PGEM_ERR_UNKNOWN_ID = -6,        /**< an edge or call names a pose that does not exist */
    PGEM_ERR_SELF_LOOP = -7,         /**< an edge from a pose to itself */
    PGEM_ERR_NOT_FINITE = -8,        /**< NaN or Inf in a pose, measurement or information */
    PGEM_ERR_INFORMATION = -9,       /**< information matrix not symmetric positive definite */
    PGEM_ERR_ROTATION = -10,         /**< quaternion far from unit length */
    PGEM_ERR_FILL_BUDGET = -11,      /**< Cholesky factor needs more than config.fill_budget */
    PGEM_ERR_NOT_POSITIVE_DEFINITE = -12, /**< normal equations singular (e.g. unfixed gauge) */
    PGEM_ERR_NUMERIC = -13,          /**< the solve produced NaN or Inf */
    PGEM_ERR_EMPTY = -14,            /**< nothing to optimize (no free pose or no edge) */
    PGEM_ERR_OUT_OF_MEMORY = -15,    /**< symbolic analysis could not get workspace */
    PGEM_ERR_WRONG_KIND = -16,       /**< edge is not a loop closure / value of wrong kind */
    PGEM_ERR_DIMENSION = -19,        /**< 2D and 3D mixed, or the wrong dimension for the call */
    PGEM_ERR_OUT_OF_RANGE = -20,     /**< a translation or information entry beyond the limits
                                          of graph.h (PGEM_TRANSLATION_LIMIT, ...) */
    PGEM_ERR_NO_FACTOR = -21         /**< no factor is current for the covariance calls
                                          (pgem/covariance.h: pgem_covariance_prepare first) */
} pgem_error_t;

/** A short constant name for an error code of the core ("PGEM_ERR_CAPACITY"); never NULL:
 * "PGEM_ERR_UNKNOWN_CODE" for any other (pgem_io_error_name names lib/io's too). */
const char *pgem_error_name(int code);

/** One sentence describing an error code of the core; never NULL ("unknown error code"). */
const char *pgem_error_description(int code);

#ifdef __cplusplus
}
#endif

#endif /* PGEM_ERROR_H */
