/* The confinement trioct-load puts itself in before it parses anything: every inherited
 * descriptor past stderr closed; death with the daemon (parent, when > 0); no new
 * privileges; no core dumps and no file writes; limits on open files, stack, CPU time
 * (seconds, 0: none) and address space (bytes, 0: none; not under AddressSanitizer, whose
 * shadow memory an address-space limit forbids); and a system-call filter refusing
 * sockets, fork and exec with EACCES. 0, or -1 with err. */
#ifndef TRIOCT_LOADER_LOADER_CONFINE_H
#define TRIOCT_LOADER_LOADER_CONFINE_H

#include <stddef.h>

int loader_confine(unsigned long long memory, unsigned cpu, long parent, char *err, size_t err_len);

#endif
