/* The one version of trioct: trioctd --version, its status messages, trioct --version and
 * the installed trioct.pc all say this. */
#ifndef TRIOCT_VERSION_H
#define TRIOCT_VERSION_H

#define TRIOCT_VERSION "0.9.0"

#endif
