// Placeholder until the linear_features plugin lands.
#include "skidimm/sdk/export.h"
