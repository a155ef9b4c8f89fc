// Placeholder until the stc_sided plugin lands.
#include "skidimm/sdk/export.h"
