/** @file
 * pgem umbrella header: the whole public C API of the core (I/O has its own, pgem/io.h). */
#ifndef PGEM_PGEM_H
#define PGEM_PGEM_H

#include "pgem/error.h"
#include "pgem/core.h"
#include "pgem/geometry.h"
#include "pgem/graph.h"
#include "pgem/solver.h"
#include "pgem/robust.h"
#include "pgem/update.h"
#include "pgem/compact.h"
#include "pgem/covariance.h"

#endif /* PGEM_PGEM_H */
