/* Union-find over pose indices (lib/support, private: not part of the installed API). The one
 * the core checks a graph's parts with (linalg's solvable check and held parts), the tools
 * count connected components with and the bridge keeps its gauge per part with.
 * parent[i] == i for a root. pgem_part_root returns i's root, halving the path on the way;
 * pgem_part_join joins the parts of a and b under the smaller of their roots and returns it,
 * so a part's root is its smallest index. No allocation, no I/O (C99, built into pgem_core, so
 * firmware has it too): the caller owns parent, one entry per pose, each set to its own index
 * first. */
#ifndef PGEM_SUPPORT_UNION_FIND_H
#define PGEM_SUPPORT_UNION_FIND_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

uint32_t pgem_part_root(uint32_t *parent, uint32_t index);
uint32_t pgem_part_join(uint32_t *parent, uint32_t a, uint32_t b);

#ifdef __cplusplus
}
#endif

#endif /* PGEM_SUPPORT_UNION_FIND_H */
