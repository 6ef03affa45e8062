// A Vulkan layer that counts the calls a GPU batch costs: render passes, dispatches,
// pipeline barriers, buffers created, command buffers begun, draws, descriptor
// updates and queue submissions. It prints the totals when the process exits (to the
// file named by VKCOUNT_OUT, else stderr). Used by benches/vkcount/run.sh; see there.
//
// One process, one driver: the next layer's entry points are kept globally (homcull
// opens one device per adapter, and every device of one driver shares them).
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <vulkan/vk_layer.h>
#include <vulkan/vulkan.h>

#define EXPORT __attribute__((visibility("default")))

enum {
    RENDER_PASSES, DISPATCHES, BARRIERS, BUFFERS, COMMAND_BUFFERS, DRAWS,
    DESCRIPTOR_WRITES, SUBMITS, COUNTERS
};
static const char *names[COUNTERS] = {
    "render_passes", "dispatches", "barriers", "buffers_created", "command_buffers_begun",
    "draw_calls", "descriptor_set_updates", "queue_submits",
};
static atomic_ulong counts[COUNTERS];

static PFN_vkGetInstanceProcAddr next_gipa;
static PFN_vkGetDeviceProcAddr next_gdpa;
static VkInstance instance;

static void report(void) {
    const char *path = getenv("VKCOUNT_OUT");
    FILE *f = path ? fopen(path, "w") : stderr;
    if (!f) return;
    fprintf(f, "{");
    for (int i = 0; i < COUNTERS; i++)
        fprintf(f, "%s\"%s\": %lu", i ? ", " : "", names[i], (unsigned long)counts[i]);
    fprintf(f, "}\n");
    if (path) fclose(f);
}

// The next layer's entry point for each counted call, and our wrapper.
#define COUNTED(ret, name, counter, params, args)                                     \
    static PFN_##name next_##name;                                                    \
    static VKAPI_ATTR ret VKAPI_CALL count_##name params {                             \
        atomic_fetch_add(&counts[counter], 1);                                        \
        return next_##name args;                                                      \
    }

COUNTED(void, vkCmdBeginRenderPass, RENDER_PASSES,
        (VkCommandBuffer c, const VkRenderPassBeginInfo *i, VkSubpassContents s), (c, i, s))
COUNTED(void, vkCmdBeginRenderPass2, RENDER_PASSES,
        (VkCommandBuffer c, const VkRenderPassBeginInfo *i, const VkSubpassBeginInfo *s), (c, i, s))
COUNTED(void, vkCmdBeginRendering, RENDER_PASSES,
        (VkCommandBuffer c, const VkRenderingInfo *i), (c, i))
COUNTED(void, vkCmdDispatch, DISPATCHES, (VkCommandBuffer c, uint32_t x, uint32_t y, uint32_t z),
        (c, x, y, z))
COUNTED(void, vkCmdDispatchIndirect, DISPATCHES, (VkCommandBuffer c, VkBuffer b, VkDeviceSize o),
        (c, b, o))
COUNTED(void, vkCmdPipelineBarrier, BARRIERS,
        (VkCommandBuffer c, VkPipelineStageFlags s, VkPipelineStageFlags d, VkDependencyFlags f,
         uint32_t nm, const VkMemoryBarrier *m, uint32_t nb, const VkBufferMemoryBarrier *b,
         uint32_t ni, const VkImageMemoryBarrier *i),
        (c, s, d, f, nm, m, nb, b, ni, i))
COUNTED(void, vkCmdPipelineBarrier2, BARRIERS, (VkCommandBuffer c, const VkDependencyInfo *d), (c, d))
COUNTED(VkResult, vkCreateBuffer, BUFFERS,
        (VkDevice d, const VkBufferCreateInfo *i, const VkAllocationCallbacks *a, VkBuffer *b),
        (d, i, a, b))
COUNTED(VkResult, vkBeginCommandBuffer, COMMAND_BUFFERS,
        (VkCommandBuffer c, const VkCommandBufferBeginInfo *i), (c, i))
COUNTED(void, vkCmdDraw, DRAWS, (VkCommandBuffer c, uint32_t v, uint32_t n, uint32_t fv, uint32_t fi),
        (c, v, n, fv, fi))
COUNTED(void, vkCmdDrawIndexed, DRAWS,
        (VkCommandBuffer c, uint32_t i, uint32_t n, uint32_t fi, int32_t vo, uint32_t fn),
        (c, i, n, fi, vo, fn))
COUNTED(void, vkCmdDrawIndexedIndirect, DRAWS,
        (VkCommandBuffer c, VkBuffer b, VkDeviceSize o, uint32_t n, uint32_t s), (c, b, o, n, s))
COUNTED(void, vkCmdDrawIndexedIndirectCount, DRAWS,
        (VkCommandBuffer c, VkBuffer b, VkDeviceSize o, VkBuffer cb, VkDeviceSize co, uint32_t m,
         uint32_t s),
        (c, b, o, cb, co, m, s))
COUNTED(void, vkUpdateDescriptorSets, DESCRIPTOR_WRITES,
        (VkDevice d, uint32_t nw, const VkWriteDescriptorSet *w, uint32_t nc,
         const VkCopyDescriptorSet *c),
        (d, nw, w, nc, c))
COUNTED(VkResult, vkQueueSubmit, SUBMITS, (VkQueue q, uint32_t n, const VkSubmitInfo *s, VkFence f),
        (q, n, s, f))
COUNTED(VkResult, vkQueueSubmit2, SUBMITS, (VkQueue q, uint32_t n, const VkSubmitInfo2 *s, VkFence f),
        (q, n, s, f))

// Name -> (our wrapper, where the next layer's pointer goes). KHR aliases share one.
static const struct {
    const char *name;
    PFN_vkVoidFunction ours;
    PFN_vkVoidFunction *next;
} table[] = {
#define ENTRY(alias, name) {alias, (PFN_vkVoidFunction)count_##name, (PFN_vkVoidFunction *)&next_##name}
    ENTRY("vkCmdBeginRenderPass", vkCmdBeginRenderPass),
    ENTRY("vkCmdBeginRenderPass2", vkCmdBeginRenderPass2),
    ENTRY("vkCmdBeginRenderPass2KHR", vkCmdBeginRenderPass2),
    ENTRY("vkCmdBeginRendering", vkCmdBeginRendering),
    ENTRY("vkCmdBeginRenderingKHR", vkCmdBeginRendering),
    ENTRY("vkCmdDispatch", vkCmdDispatch),
    ENTRY("vkCmdDispatchIndirect", vkCmdDispatchIndirect),
    ENTRY("vkCmdPipelineBarrier", vkCmdPipelineBarrier),
    ENTRY("vkCmdPipelineBarrier2", vkCmdPipelineBarrier2),
    ENTRY("vkCmdPipelineBarrier2KHR", vkCmdPipelineBarrier2),
    ENTRY("vkCreateBuffer", vkCreateBuffer),
    ENTRY("vkBeginCommandBuffer", vkBeginCommandBuffer),
    ENTRY("vkCmdDraw", vkCmdDraw),
    ENTRY("vkCmdDrawIndexed", vkCmdDrawIndexed),
    ENTRY("vkCmdDrawIndexedIndirect", vkCmdDrawIndexedIndirect),
    ENTRY("vkCmdDrawIndexedIndirectCount", vkCmdDrawIndexedIndirectCount),
    ENTRY("vkCmdDrawIndexedIndirectCountKHR", vkCmdDrawIndexedIndirectCount),
    ENTRY("vkUpdateDescriptorSets", vkUpdateDescriptorSets),
    ENTRY("vkQueueSubmit", vkQueueSubmit),
    ENTRY("vkQueueSubmit2", vkQueueSubmit2),
    ENTRY("vkQueueSubmit2KHR", vkQueueSubmit2),
#undef ENTRY
};
#define TABLE_LEN (sizeof table / sizeof table[0])

static VKAPI_ATTR VkResult VKAPI_CALL count_vkCreateInstance(const VkInstanceCreateInfo *ci,
                                                             const VkAllocationCallbacks *a,
                                                             VkInstance *out) {
    VkLayerInstanceCreateInfo *link = (VkLayerInstanceCreateInfo *)ci->pNext;
    while (link && !(link->sType == VK_STRUCTURE_TYPE_LOADER_INSTANCE_CREATE_INFO &&
                     link->function == VK_LAYER_LINK_INFO))
        link = (VkLayerInstanceCreateInfo *)link->pNext;
    if (!link) return VK_ERROR_INITIALIZATION_FAILED;
    next_gipa = link->u.pLayerInfo->pfnNextGetInstanceProcAddr;
    link->u.pLayerInfo = link->u.pLayerInfo->pNext;
    PFN_vkCreateInstance create = (PFN_vkCreateInstance)next_gipa(NULL, "vkCreateInstance");
    VkResult r = create(ci, a, out);
    if (r == VK_SUCCESS) {
        static int once;
        instance = *out;
        if (!once++) atexit(report);
    }
    return r;
}

static VKAPI_ATTR VkResult VKAPI_CALL count_vkCreateDevice(VkPhysicalDevice pd,
                                                           const VkDeviceCreateInfo *ci,
                                                           const VkAllocationCallbacks *a,
                                                           VkDevice *out) {
    VkLayerDeviceCreateInfo *link = (VkLayerDeviceCreateInfo *)ci->pNext;
    while (link && !(link->sType == VK_STRUCTURE_TYPE_LOADER_DEVICE_CREATE_INFO &&
                     link->function == VK_LAYER_LINK_INFO))
        link = (VkLayerDeviceCreateInfo *)link->pNext;
    if (!link) return VK_ERROR_INITIALIZATION_FAILED;
    PFN_vkGetInstanceProcAddr gipa = link->u.pLayerInfo->pfnNextGetInstanceProcAddr;
    next_gdpa = link->u.pLayerInfo->pfnNextGetDeviceProcAddr;
    link->u.pLayerInfo = link->u.pLayerInfo->pNext;
    PFN_vkCreateDevice create = (PFN_vkCreateDevice)gipa(instance, "vkCreateDevice");
    VkResult r = create(pd, ci, a, out);
    if (r != VK_SUCCESS) return r;
    for (size_t i = 0; i < TABLE_LEN; i++) {
        PFN_vkVoidFunction f = next_gdpa(*out, table[i].name);
        if (f) *table[i].next = f;
    }
    return r;
}

EXPORT VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL vkcount_GetDeviceProcAddr(VkDevice d, const char *name);

static PFN_vkVoidFunction ours(const char *name) {
    for (size_t i = 0; i < TABLE_LEN; i++)
        if (!strcmp(name, table[i].name)) return *table[i].next ? table[i].ours : NULL;
    return NULL;
}

EXPORT VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL vkcount_GetDeviceProcAddr(VkDevice d, const char *name) {
    if (!strcmp(name, "vkGetDeviceProcAddr")) return (PFN_vkVoidFunction)vkcount_GetDeviceProcAddr;
    PFN_vkVoidFunction f = ours(name);
    return f ? f : next_gdpa(d, name);
}

EXPORT VKAPI_ATTR PFN_vkVoidFunction VKAPI_CALL vkcount_GetInstanceProcAddr(VkInstance i, const char *name) {
    if (!strcmp(name, "vkGetInstanceProcAddr")) return (PFN_vkVoidFunction)vkcount_GetInstanceProcAddr;
    if (!strcmp(name, "vkGetDeviceProcAddr")) return (PFN_vkVoidFunction)vkcount_GetDeviceProcAddr;
    if (!strcmp(name, "vkCreateInstance")) return (PFN_vkVoidFunction)count_vkCreateInstance;
    if (!strcmp(name, "vkCreateDevice")) return (PFN_vkVoidFunction)count_vkCreateDevice;
    PFN_vkVoidFunction f = next_gdpa ? ours(name) : NULL;
    return f ? f : next_gipa(i, name);
}
