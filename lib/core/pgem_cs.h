/* The CSparse interface the core uses: CXSparse's int/double flavour (cs_di_*). */
#ifndef PGEM_CS_H
#define PGEM_CS_H

#ifndef NCOMPLEX
#define NCOMPLEX /* the core uses only the real routines; keeps <complex.h> out */
#endif
#include "cs.h"

#endif /* PGEM_CS_H */
