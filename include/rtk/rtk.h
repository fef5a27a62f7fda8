/* Umbrella header of the rtk plugin SDK. */
#ifndef RTK_RTK_H
#define RTK_RTK_H

#include <rtk/common.h>
#include <rtk/log.h>
#include <rtk/parallel.h>
#include <rtk/math.h>
#include <rtk/ray.h>
#include <rtk/params.h>
#include <rtk/plugin.h>
#include <rtk/scene.h>
#include <rtk/sampler.h>
#include <rtk/bsdf.h>
#include <rtk/lights.h>
#include <rtk/integrator.h>
#include <rtk/accelerator.h>
#include <rtk/filter.h>

#endif
